//! `kalfmu s1-export`: writes the input table of one S1 case — the noisy
//! accelerations the estimator sees and the true load — as CSV, so that an
//! importer (fmpy in the Python suite) can drive the S1 estimator FMU with
//! exactly the data of the study.
//!
//! The file:
//!
//! ```text
//! # kalfmu S1 input table (kalfmu s1-export)
//! # case = stiffness/random
//! # seed = 1
//! # noise_fraction = 0.02
//! # sample_time = 0.005
//! # z1_ddot_noise_std = 0.0123…
//! # z2_ddot_noise_std = 0.0456…
//! time,z1_ddot,z2_ddot,F_true
//! 0,…,…,…
//! 0.005,…,…,…
//! ```
//!
//! * The `#` lines are `key = value` metadata; the two `*_noise_std` values
//!   are the standard deviations of the white noise added to each channel
//!   (m/s²): the sensor specification, to be set as `r_z1_ddot_std` and
//!   `r_z2_ddot_std` of the FMU.
//! * Then one header line and one row per sample `k = 0 … n` at
//!   `time = k·dt`: the measured accelerations `z1_ddot`, `z2_ddot` (m/s²) at
//!   that time, and the true load `F_true` (N) there. They are the plant's
//!   outputs of that time: a master sets row `k` at communication point `tₖ`,
//!   as fmpy does with an input table, and the FMU measures them at `tₖ`.
//! * Numbers are written in Rust's shortest round-trip form: parsing them
//!   back gives the same `f64`s.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;

use anyhow::Context;

use truth::s1::plant::Truth;
use truth::s1::{Case, Measurements, Settings};

/// Command-line arguments of `kalfmu s1-export`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The case: stiffness/random, damping/random, stiffness/harmonic or damping/harmonic.
    #[arg(long, default_value = "stiffness/random")]
    pub case: Case,
    /// Simulated duration in seconds.
    #[arg(long, default_value_t = Settings::default().duration)]
    pub duration: f64,
    /// Seed of the random load and of the measurement noise.
    #[arg(long, default_value_t = Settings::default().seed)]
    pub seed: u64,
    /// Accelerometer noise as a fraction of each channel's RMS.
    #[arg(long, default_value_t = Settings::default().noise_fraction)]
    pub noise: f64,
    /// The CSV file to write.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let settings =
        Settings { duration: args.duration, seed: args.seed, noise_fraction: args.noise, ..Settings::default() };
    settings.validate().map_err(anyhow::Error::msg)?;
    let (truth, measurements) = truth::s1::simulate(&args.case, &settings);
    let file = File::create(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut out = BufWriter::new(file);
    write_table(&mut out, &args.case, &settings, &truth, &measurements)
        .and_then(|()| out.flush())
        .with_context(|| format!("cannot write {}", args.out.display()))
}

/// Writes the table described in the module documentation.
pub fn write_table<W: Write>(
    out: &mut W,
    case: &Case,
    settings: &Settings,
    truth: &Truth,
    measurements: &Measurements,
) -> std::io::Result<()> {
    writeln!(out, "# kalfmu S1 input table (kalfmu s1-export)")?;
    writeln!(out, "# case = {case}")?;
    writeln!(out, "# seed = {}", settings.seed)?;
    writeln!(out, "# noise_fraction = {}", settings.noise_fraction)?;
    writeln!(out, "# sample_time = {}", settings.dt())?;
    writeln!(out, "# z1_ddot_noise_std = {}", measurements.noise_std[0])?;
    writeln!(out, "# z2_ddot_noise_std = {}", measurements.noise_std[1])?;
    writeln!(out, "time,z1_ddot,z2_ddot,F_true")?;
    for ((t, z), f) in truth.time.iter().zip(&measurements.acceleration).zip(&truth.load) {
        writeln!(out, "{t},{},{},{f}", z[0], z[1])?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_round_trips_the_simulated_data_with_its_noise_levels() {
        let case: Case = "damping/harmonic".parse().unwrap();
        let settings = Settings { duration: 0.1, seed: 3, ..Settings::default() };
        let (truth, measurements) = truth::s1::simulate(&case, &settings);
        let mut bytes = Vec::new();
        write_table(&mut bytes, &case, &settings, &truth, &measurements).unwrap();
        let text = String::from_utf8(bytes).unwrap();
        let meta = |key: &str| -> f64 {
            let prefix = format!("# {key} = ");
            text.lines().find_map(|l| l.strip_prefix(prefix.as_str())).unwrap().parse().unwrap()
        };
        assert!(text.contains("# case = damping/harmonic\n"));
        assert_eq!(meta("sample_time"), 0.005);
        assert_eq!(meta("z1_ddot_noise_std"), measurements.noise_std[0]);
        assert_eq!(meta("z2_ddot_noise_std"), measurements.noise_std[1]);
        let rows: Vec<Vec<f64>> = text
            .lines()
            .skip_while(|l| l.starts_with('#'))
            .skip(1)
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), 21, "t = 0, 0.005, …, 0.1");
        for (k, row) in rows.iter().enumerate() {
            let z = measurements.acceleration[k];
            assert_eq!(row, &vec![truth.time[k], z[0], z[1], truth.load[k]]);
        }
        assert!("stiffness/sine".parse::<Case>().unwrap_err().contains("expected one of stiffness/random"));
    }
}

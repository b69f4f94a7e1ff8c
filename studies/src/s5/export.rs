//! `kalfmu s5-export`: writes the input table of the S5 flight — the noisy
//! measurements and the deflections the estimator FMU takes, and the true coefficients —
//! as CSV, so that an importer (fmpy in the Python suite) drives the S5 estimator FMU with
//! exactly the data of the study.
//!
//! The file:
//!
//! ```text
//! # kalfmu S5 input table (kalfmu s5-export)
//! # seed = 1
//! # sample_time = 0.005
//! # r_omega_x_std = 0.001
//! …
//! time,omega_x,…,beta,delta_x,delta_y,delta_z,true_Cx0,…,true_Cz_d
//! 0,…
//! ```
//!
//! * The `#` lines are `key = value` metadata; the `r_<measurement>_std` values are the
//!   standard deviations of the white noise added to each measurement (its unit), the
//!   sensor specification, named as the FMU's parameters that take them.
//! * Then one header line and one row per sample `k = 0 … n` at `time = k·dt`: the twelve
//!   measurements of that time, the deflections (rad) the control computer holds from that
//!   time on, and the coefficients in force from then. A master sets the measurements and
//!   the deflections of row `k` at communication point `tₖ`.
//! * Numbers are written in Rust's shortest round-trip form.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;

use anyhow::Context;
use estimator::models::Missile6Dof;

use truth::s5::flight::{measure, simulate, Settings, Truth};
use truth::s5::parameters::{NAMES, SENSOR_STD};

/// The deflections' names, as the FMU's control inputs.
const DEFLECTIONS: [&str; 3] = ["delta_x", "delta_y", "delta_z"];

/// Command-line arguments of `kalfmu s5-export`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// How much of the flight to write, in seconds from launch (the whole flight is 20 s).
    #[arg(long, default_value_t = 20.0)]
    pub duration: f64,
    /// Seed of the measurement noise.
    #[arg(long, default_value_t = Settings::default().seed)]
    pub seed: u64,
    /// The CSV file to write.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    anyhow::ensure!(args.duration >= 0.0, "--duration must be a non-negative number of seconds, not {}", args.duration);
    let settings = Settings { seed: args.seed, ..Settings::default() };
    let truth = simulate(&settings);
    let measurements = measure(&truth, settings.noise_scale, settings.seed);
    let rows = truth.time.iter().take_while(|&&t| t <= args.duration + 1e-9).count();
    let file = File::create(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut out = BufWriter::new(file);
    write_table(&mut out, &settings, &truth, &measurements, rows)
        .and_then(|()| out.flush())
        .with_context(|| format!("cannot write {}", args.out.display()))
}

/// Writes the first `rows` samples as the table of the module documentation.
pub fn write_table<W: Write>(
    out: &mut W,
    settings: &Settings,
    truth: &Truth,
    measurements: &[[f64; 12]],
    rows: usize,
) -> std::io::Result<()> {
    writeln!(out, "# kalfmu S5 input table (kalfmu s5-export)")?;
    writeln!(out, "# seed = {}", settings.seed)?;
    writeln!(out, "# sample_time = {}", settings.sample_time)?;
    for (name, std) in Missile6Dof::MEASUREMENT_NAMES.iter().zip(SENSOR_STD) {
        writeln!(out, "# r_{name}_std = {}", settings.noise_scale * std)?;
    }
    let header: Vec<String> = ["time"]
        .iter()
        .chain(&Missile6Dof::MEASUREMENT_NAMES)
        .chain(&DEFLECTIONS)
        .map(|s| s.to_string())
        .chain(NAMES.iter().map(|c| format!("true_{c}")))
        .collect();
    writeln!(out, "{}", header.join(","))?;
    let samples = truth.time.iter().zip(measurements).zip(&truth.deflections).zip(&truth.coefficients);
    for (((t, z), delta), c) in samples.take(rows) {
        let row: Vec<String> = std::iter::once(t).chain(z).chain(delta).chain(c).map(|v| v.to_string()).collect();
        writeln!(out, "{}", row.join(","))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_round_trips_the_flight_with_its_sensor_specification() {
        let settings = Settings { seed: 3, ..Settings::default() };
        let truth = simulate(&settings);
        let measurements = measure(&truth, 1.0, 3);
        let mut bytes = Vec::new();
        write_table(&mut bytes, &settings, &truth, &measurements, 21).unwrap();
        let text = String::from_utf8(bytes).unwrap();
        let meta = |key: &str| -> f64 {
            let prefix = format!("# {key} = ");
            text.lines().find_map(|l| l.strip_prefix(prefix.as_str())).unwrap().parse().unwrap()
        };
        assert_eq!(meta("sample_time"), 0.005);
        assert_eq!(meta("r_h_std"), 1.0);
        assert_eq!(meta("r_alpha_std"), 2e-3);
        let mut body = text.lines().skip_while(|l| l.starts_with('#'));
        let header: Vec<&str> = body.next().unwrap().split(',').collect();
        assert_eq!(header.len(), 1 + 12 + 3 + 10);
        assert_eq!((header[1], header[13], header[16], header[25]), ("omega_x", "delta_x", "true_Cx0", "true_Cz_d"));
        let rows: Vec<Vec<f64>> = body.map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
        assert_eq!(rows.len(), 21, "t = 0, 0.005, …, 0.1");
        for (k, row) in rows.iter().enumerate() {
            assert_eq!(row[0], truth.time[k]);
            assert_eq!(row[1..13], measurements[k]);
            assert_eq!(row[13..16], truth.deflections[k]);
            assert_eq!(row[16..], truth.coefficients[k]);
        }
    }
}

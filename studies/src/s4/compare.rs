//! `kalfmu s4-compare`: on one profile and noise seed after another, the raw average
//! of the four channels, the paper's pipeline (Grubbs' test, support replacement, adaptive
//! weights, the UKF on the fused speed; [`super::paper`]) and ours (a filter on the four
//! positions with their offsets as states, behind the supervisor; [`super::ours`]), all
//! in-process on the same recording, scored against the true speed and position
//! ([`super::metrics`]) beside the paper's figures. Seeds are spread over both cores
//! (`--shard K/N`). `--faults frequent` runs the channels with ten times the default fault
//! rates, a case the tuning was not chosen on; `--set`/`--values` change our filter's tuning by
//! the FMU's parameter names ([`Tuning::set`]).

use std::fmt::Write as _;

use estimator::FilterKind;

use super::metrics::{
    fraction_in_band, reduction, score_detection, score_position, score_speed, true_position_for_samples,
    true_speed_for_samples, DetectionScore, DetectionSettings, SpeedScore, FAULT_KINDS,
};
use super::ours::{self, Settings, Tuning};
use super::paper::{raw_average, raw_average_position, run_paper, PaperSettings};
use crate::shard::{self, Shard};
use start_values::{SetByName, StartValues};
use truth::s4::channels::{simulate, Channel};
use truth::s4::faults::{FaultKind, FaultProfile, Faults};
use truth::s4::profile::Profile;
use truth::s4::recording::Recording;

/// The paper's figures (§3.2): mean speed error 0.12 → 0.08 m/s (−32.6 %), speed range
/// 11.09 → 5.62 m/s (−49.3 %) against a true range of 5.6 m/s.
pub(crate) const PAPER_MEAN_REDUCTION: f64 = 0.326;
/// The paper's speed range before and after its pipeline (m/s).
pub(crate) const PAPER_RANGE: (f64, f64) = (11.09, 5.62);

/// How close an offset estimate must come to be counted as found (m): its difference
/// from the four channels' mean offset (the only part the channels observe) within this
/// of the truth's. Twice the position noise.
const OFFSET_FOUND_WITHIN: f64 = 0.003;

/// Which motion to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Motion {
    /// The paper's test run: 0.2 → 5.6 m/s at 2.5 m/s², a stop at 506.4 m.
    Paper,
    /// A jerk-limited run to 500 km/h and back to a stop.
    HighSpeed,
}

/// Command-line arguments of `kalfmu s4-compare`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The motion.
    #[arg(long, value_enum, default_value = "paper")]
    pub profile: Motion,
    /// Noise and fault seeds 1 … this.
    #[arg(long, default_value_t = 1)]
    pub seeds: u64,
    /// The channels' fault model: default, frequent (the default's rates ×10) or none.
    #[arg(long, default_value = "default")]
    pub faults: FaultProfile,
    /// Our filter's kind.
    #[arg(long, default_value_t = FilterKind::SrCkf)]
    pub filter: FilterKind,
    /// Run only the seeds K, K + N, … of the N (1-based): `--shard 2/4`.
    #[arg(long, default_value = "1/1")]
    pub shard: Shard,
    /// Our filter's tuning, by the FMU's parameter names, over the profile's (`--set
    /// jerk_intensity=3`); a name the in-process filter does not take is an error.
    #[command(flatten)]
    pub start_values: start_values::Options,
}

/// One estimator's scores on one recording.
#[derive(serde::Serialize)]
struct Scores {
    speed: SpeedScore,
    #[serde(rename = "position_max_abs_error")]
    position_max: f64,
    #[serde(rename = "in_etcs_band_fraction")]
    in_band: f64,
}

/// One recording's comparison.
#[derive(serde::Serialize)]
pub(crate) struct Comparison {
    #[serde(rename = "raw_average")]
    raw: Scores,
    #[serde(rename = "paper_fused")]
    fused: Scores,
    #[serde(rename = "paper_fused_ukf")]
    filtered: Scores,
    ours: Scores,
    paper_detection: DetectionScore,
    our_detection: DetectionScore,
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let kind = args.filter;
    let (profile, mut tuning) = match args.profile {
        Motion::Paper => (Profile::paper(), Tuning::paper()),
        Motion::HighSpeed => (Profile::high_speed(), Tuning::jerk_limited()),
    };
    let start_values = StartValues::from_options(&args.start_values).map_err(anyhow::Error::msg)?;
    tuning.set_all(&start_values).map_err(anyhow::Error::msg)?;
    let faults = args.faults;
    let seeds: Vec<u64> = (1..=args.seeds).collect();
    let results = shard::run(&seeds, args.shard, |&seed| compare(&profile, &faults.faults(), &tuning, kind, seed));
    let mut out = String::new();
    let _ = writeln!(
        out,
        "S4: speed and position from four PRW position channels, {:?} profile ({:.1} s, telegrams every 0.02 s), {faults} faults (docs/studies/s4.md); in-process, ours {kind}",
        args.profile,
        profile.duration()
    );
    if !start_values.is_empty() {
        let _ = writeln!(out, "our filter's tuning with the start values {}", start_values.summary());
    }
    for (j, result) in results {
        let seed = seeds[j];
        match result {
            Ok(c) => print_comparison(&mut out, seed, faults, &c),
            Err(e) => {
                let _ = writeln!(out, "seed {seed}: failed: {e}");
            }
        }
    }
    print!("{out}");
    Ok(())
}

fn compare(
    profile: &Profile,
    faults: &Faults,
    tuning: &Tuning,
    kind: FilterKind,
    seed: u64,
) -> Result<Comparison, String> {
    let recording = simulate(profile, faults, seed);
    let ours = ours::run(&recording, &Settings::new(kind, *tuning))?;
    // Ours at the telegrams the speed samples are known at, 1 … n − 1.
    let later = &ours.estimates[1..];
    let speed: Vec<f64> = later.iter().map(|e| e.speed).collect();
    let position: Vec<f64> = later.iter().map(|e| e.position).collect();
    compare_with(&recording, &ours, &speed, &position)
}

/// The raw average and the paper's pipeline on `recording`, and ours: the run `ours`
/// (its flags, offsets and slips), whose speed and position at telegrams 1 … n − 1 are
/// `our_speed` and `our_position` (the run's own, or an FMU's that ran the same filter).
pub(crate) fn compare_with(
    recording: &Recording,
    ours: &ours::Run,
    our_speed: &[f64],
    our_position: &[f64],
) -> Result<Comparison, String> {
    let speed_truth = true_speed_for_samples(recording);
    let position_truth = true_position_for_samples(recording);
    let scores = |speed: &[f64], position: &[f64]| Scores {
        speed: score_speed(speed, &speed_truth),
        position_max: score_position(position, &position_truth).max_abs,
        in_band: fraction_in_band(speed, &speed_truth),
    };
    let paper = run_paper(recording, &PaperSettings::default()).map_err(|e| format!("paper's pipeline: {e}"))?;
    let raw_position: Vec<f64> = raw_average_position(recording).into_iter().skip(1).collect();
    let our_flags: Vec<[bool; 4]> = ours
        .estimates
        .iter()
        .map(|e| std::array::from_fn(|c| e.stale[c] || e.rejected[c] || e.slip[c] != 0.0))
        .collect();
    let settings = DetectionSettings::default();
    Ok(Comparison {
        raw: scores(&raw_average(recording), &raw_position),
        fused: scores(&paper.fused, &paper.position),
        filtered: scores(&paper.filtered, &paper.position),
        ours: scores(our_speed, our_position),
        paper_detection: score_detection(&recording.faults, &paper.flags_by_telegram(), [false; 4], settings),
        our_detection: score_detection(&recording.faults, &our_flags, offsets_found(recording, ours), settings),
    })
}

/// Per channel: its offset, relative to the four channels' mean, estimated within
/// [`OFFSET_FOUND_WITHIN`] of the truth's at the end of the run (slips re-based out).
fn offsets_found(recording: &Recording, run: &ours::Run) -> [bool; 4] {
    let mut installed = [0.0; 4];
    for fault in &recording.faults {
        if let FaultKind::Offset { error } = fault.kind {
            installed[fault.channel as usize] = error;
        }
    }
    let last = run.estimates.last().map_or([f64::NAN; 4], |e| e.offsets);
    let rebased: [f64; 4] = std::array::from_fn(|c| {
        let channel = Channel::ALL[c];
        run.slips.iter().filter(|s| s.channel == channel).map(|s| s.step).sum()
    });
    let estimated: [f64; 4] = std::array::from_fn(|c| last[c] - rebased[c]);
    let mean = |x: &[f64; 4]| x.iter().sum::<f64>() / 4.0;
    let (estimated_mean, installed_mean) = (mean(&estimated), mean(&installed));
    std::array::from_fn(|c| {
        ((estimated[c] - estimated_mean) - (installed[c] - installed_mean)).abs() <= OFFSET_FOUND_WITHIN
    })
}

/// Prints one comparison's tables under the heading `seed {seed}: …`; the paper's figures
/// beside them only for the fault model they are compared with (`default`).
pub(crate) fn print_comparison(out: &mut String, seed: u64, faults: FaultProfile, c: &Comparison) {
    let _ = writeln!(out, "seed {seed}: speed against the true speed at the telegram each estimate is known (m/s)");
    let _ = writeln!(
        out,
        "{:<22} {:>9} {:>9} {:>9} {:>12} {:>9} {:>10} {:>8}",
        "", "mean |e|", "vs raw", "max |e|", "speed range", "e range", "pos |e|max", "in ETCS"
    );
    let rows =
        [("raw average", &c.raw), ("paper: fused", &c.fused), ("paper: fused + UKF", &c.filtered), ("ours", &c.ours)];
    for (j, (name, s)) in rows.into_iter().enumerate() {
        let against_raw = -100.0 * reduction(c.raw.speed.mean_abs_error, s.speed.mean_abs_error);
        let _ = writeln!(
            out,
            "{:<22} {:>9.4} {:>9} {:>9.3} {:>12.3} {:>9.3} {:>10.4} {:>7.2}%",
            name,
            s.speed.mean_abs_error,
            if j == 0 { "—".to_string() } else { format!("{against_raw:.1}%") },
            s.speed.max_abs_error,
            s.speed.speed_range,
            s.speed.error_range,
            s.position_max,
            100.0 * s.in_band
        );
    }
    if faults == FaultProfile::Default {
        let _ = writeln!(
            out,
            "{:<22} true range {:.3}; the paper: mean error −{:.1} %, speed range {} → {} m/s (−{:.1} %)",
            "",
            c.raw.speed.true_range,
            100.0 * PAPER_MEAN_REDUCTION,
            PAPER_RANGE.0,
            PAPER_RANGE.1,
            100.0 * reduction(PAPER_RANGE.0, PAPER_RANGE.1)
        );
    } else {
        let _ = writeln!(
            out,
            "{:<22} true range {:.3}; the paper has no figures of {faults} faults",
            "", c.raw.speed.true_range
        );
    }
    let _ = writeln!(out, "{:<22} {:>9} {:>15} {:>15}", "faults", "injected", "paper detected", "ours detected");
    for (j, name) in FAULT_KINDS.iter().enumerate() {
        let (p, o) = (&c.paper_detection.kinds[j], &c.our_detection.kinds[j]);
        let _ = writeln!(out, "{:<22} {:>9} {:>15} {:>15}", name, p.injected, p.detected, o.detected);
    }
    let _ = writeln!(
        out,
        "{:<22} {:>9} {:>14.3}% {:>14.3}%",
        "false alarms",
        "",
        100.0 * c.paper_detection.false_alarm_fraction(),
        100.0 * c.our_detection.false_alarm_fraction()
    );
}

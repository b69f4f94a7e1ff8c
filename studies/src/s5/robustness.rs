//! `kalfmu s5-robustness`: where each filter kind fails or diverges on S5. Conditions
//! tried: the paper's own sensors, a thousand times finer than ours, with `R` to
//! match (a tiny `R`); our sensors with `R` told a thousand times too small; a long run
//! (the manoeuvre flown five times, 100 s, the coefficients constant); a flight with no
//! rudder input (the control derivatives unobservable). Every filter runs behind the
//! supervisor with its defaults, as in the FMU; the noise seeds are spread over both
//! cores (`--shard K/N`). `--set`/`--values` change every condition's tuning by the FMU's
//! parameter names ([`Tuning::set`]): a value given replaces the condition's own (an
//! `r_<measurement>_std` the `R` a condition tells the filter).

use std::fmt::Write as _;

use estimator::{FilterKind, SupervisorSettings};

use super::study::{run_supervised, Tuning};
use crate::shard::{self, Shard};
use start_values::{SetByName, StartValues};
use truth::s5::flight::{flight, measure, simulate_flight, Settings};
use truth::s5::manoeuvre::Manoeuvre;
use truth::s5::parameters::{BEFORE, NAMES};
use truth::s5::plant::Flight;

/// Command-line arguments of `kalfmu s5-robustness`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Noise seeds per condition and filter.
    #[arg(long, default_value_t = 5)]
    pub seeds: u64,
    /// Run only the runs K, K + N, … of the N (1-based): `--shard 2/4`.
    #[arg(long, default_value = "1/1")]
    pub shard: Shard,
    /// Every condition's tuning, by the FMU's parameter names, over the condition's; a name
    /// the in-process filter does not take is an error.
    #[command(flatten)]
    pub start_values: start_values::Options,
}

/// A run's end: the worst coefficient, its relative error and its error over σ, and
/// whether the supervisor calls the filter healthy; or why the filter failed.
type Outcome = Result<(usize, f64, f64, bool), String>;

/// One condition of the sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Condition {
    /// The study as it is.
    Nominal,
    /// Sensors 1000 times finer, `R` to match.
    FineSensors,
    /// Our sensors, `R` told 1000 times too small (in variance: 1e6).
    OverconfidentR,
    /// The same with the gate off: the filter's numerics alone.
    OverconfidentRUngated,
    /// The manoeuvre five times in a row, the coefficients constant.
    LongRun,
    /// No rudder input for 20 s.
    NoExcitation,
}

impl Condition {
    const ALL: [Condition; 6] = [
        Condition::Nominal,
        Condition::FineSensors,
        Condition::OverconfidentR,
        Condition::OverconfidentRUngated,
        Condition::LongRun,
        Condition::NoExcitation,
    ];

    fn name(&self) -> &'static str {
        match self {
            Condition::Nominal => "nominal",
            Condition::FineSensors => "sensors/1000, R to match",
            Condition::OverconfidentR => "R told /1000 (std)",
            Condition::OverconfidentRUngated => "R told /1000, no gate",
            Condition::LongRun => "100 s, 5 manoeuvres",
            Condition::NoExcitation => "no rudder input",
        }
    }

    fn flight(&self) -> Flight {
        let standard = flight();
        match self {
            Condition::LongRun => {
                Flight { coefficients: [BEFORE, BEFORE], manoeuvre: standard.manoeuvre.repeated(5), ..standard }
            }
            Condition::NoExcitation => {
                Flight { coefficients: [BEFORE, BEFORE], manoeuvre: Manoeuvre::quiet(20.0), ..standard }
            }
            _ => standard,
        }
    }

    /// The sensors' noise scale and the tuning, with `start_values` over the condition's.
    fn sensors_and_tuning(&self, start_values: &StartValues) -> Result<(f64, Tuning), String> {
        let (scale, mut tuning) = match self {
            Condition::FineSensors => (1e-3, Tuning::new(1e-3)),
            Condition::OverconfidentR | Condition::OverconfidentRUngated => (1.0, Tuning::new(1e-3)),
            _ => (1.0, Tuning::new(1.0)),
        };
        tuning.set_all(start_values)?;
        Ok((scale, tuning))
    }
}

/// Runs every condition with every filter kind and prints one table.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let start_values = StartValues::from_options(&args.start_values).map_err(anyhow::Error::msg)?;
    // Before any flight is flown: a misspelt name costs no run.
    let tunings: Vec<(f64, Tuning)> = Condition::ALL
        .iter()
        .map(|c| c.sensors_and_tuning(&start_values))
        .collect::<Result<_, _>>()
        .map_err(anyhow::Error::msg)?;
    let settings = Settings::default();
    let truths: Vec<_> = Condition::ALL
        .iter()
        .map(|c| simulate_flight(&c.flight(), &settings))
        .collect::<Result<_, _>>()
        .map_err(anyhow::Error::msg)?;
    let jobs: Vec<(usize, FilterKind, u64)> = (0..Condition::ALL.len())
        .flat_map(|c| FilterKind::ALL.into_iter().flat_map(move |f| (1..=args.seeds).map(move |s| (c, f, s))))
        .collect();
    let results = shard::run(&jobs, args.shard, |&(c, filter, seed)| {
        let (scale, tuning) = &tunings[c];
        let truth = &truths[c];
        let z = measure(truth, *scale, seed);
        let end = truth.time.len() - 1;
        let supervision = match Condition::ALL[c] {
            Condition::OverconfidentRUngated => {
                SupervisorSettings { gate_probability: 1.0, ..SupervisorSettings::default() }
            }
            _ => SupervisorSettings::default(),
        };
        run_supervised(filter, tuning, truth, &z, settings.sample_time, &[], supervision).map(|e| {
            // The worst coefficient's relative error at the end, and its σ ratio.
            let (i, relative, sigmas) = (0..10)
                .map(|i| {
                    let error = e.coefficients[end][i] - truth.coefficients[end][i];
                    (i, error / truth.coefficients[end][i].abs(), error.abs() / e.std[end][i])
                })
                .fold((0, 0.0_f64, 0.0_f64), |w, r| if r.1.abs() > w.1.abs() { r } else { w });
            (i, relative, sigmas, e.healthy[end])
        })
    });
    let mut out = String::new();
    let _ = writeln!(
        out,
        "S5 robustness: every filter behind the supervisor, {} noise seeds per cell; at the end of the run",
        args.seeds
    );
    if !start_values.is_empty() {
        let _ = writeln!(out, "every condition's tuning with the start values {}", start_values.summary());
    }
    let _ = writeln!(
        out,
        "{:<26} {:<8} {:>7} {:>28} {:>10} {:>8}",
        "condition", "filter", "failed", "worst coefficient (median)", "|err|/σ", "healthy"
    );
    for (c, condition) in Condition::ALL.iter().enumerate() {
        for filter in FilterKind::ALL {
            let cell: Vec<&(usize, Outcome)> =
                results.iter().filter(|(j, _)| jobs[*j].0 == c && jobs[*j].1 == filter).collect();
            if cell.is_empty() {
                continue;
            }
            let failures: Vec<&String> = cell.iter().filter_map(|(_, r)| r.as_ref().err()).collect();
            let mut worst: Vec<(usize, f64, f64, bool)> =
                cell.iter().filter_map(|(_, r)| r.as_ref().ok().copied()).collect();
            let healthy = worst.iter().filter(|w| w.3).count();
            worst.sort_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
            let median = worst.get(worst.len() / 2);
            let _ = writeln!(
                out,
                "{:<26} {:<8} {:>3}/{:<3} {:>28} {:>10} {:>8}",
                condition.name(),
                filter.name(),
                failures.len(),
                cell.len(),
                median.map_or("—".into(), |(i, r, _, _)| format!("{} {:+.3} %", NAMES[*i], 100.0 * r)),
                median.map_or("—".into(), |(_, _, s, _)| format!("{s:.1}")),
                format!("{healthy}/{}", worst.len())
            );
            if let Some(first) = failures.first() {
                let _ = writeln!(out, "{:<26}   first failure: {first}", "");
            }
        }
    }
    print!("{out}");
    Ok(())
}

//! What `kalfmu-tune` says about a fit: the table of estimates with their intervals, the
//! log-likelihood, the consistency of the fitted filter (mean NIS per row against its χ²
//! band), the `--set NAME=VALUE` lines, and the estimates as an SSV parameter set.

use std::fmt::Write as _;

use kalfmu_fmu::variables::UNITS;

use crate::consistency::NisBand;
use crate::fit::Fit;
use crate::intervals::SetAside;
use crate::likelihood::RobustCap;
use start_values::ssv::{Parameter, ParameterSet, Unit, ValueKind};
use start_values::Assignment;

/// A number in 4 significant digits, exponent form when large or small.
fn number(v: f64) -> String {
    if v == 0.0 || (1e-3..1e4).contains(&v.abs()) {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}

/// The text of a fit of the parameters `names` (with their `units`).
pub fn text(fit: &Fit, names: &[String], units: &[Option<&str>], cap: RobustCap) -> String {
    let mut t = String::new();
    let s = &fit.search;
    let _ = writeln!(
        t,
        "search: Nelder-Mead, {} iterations, {} evaluations, {} ({:.2} s); refinement: {} Newton step(s), {} \
         evaluations for the steps, gradients and curvature ({:.2} s); {}",
        s.iterations,
        s.evaluations,
        if s.converged { "converged" } else { "stopped at the iteration limit" },
        fit.search_time.as_secs_f64(),
        fit.refinements,
        fit.curvature_evaluations,
        fit.curvature_time.as_secs_f64(),
        match (fit.converged, fit.remaining_gain) {
            (true, Some(g)) => format!("at a maximum (a further step would gain {g:.1e})"),
            (false, Some(g)) => format!("NOT at a maximum: a further step would gain {g:.3} (raise --refinements)"),
            (_, None) => "the curvature is unknown (the filter failed near the estimate)".into(),
        }
    );
    let width = names.iter().map(|n| n.len()).max().unwrap_or(9).max(9);
    let _ = writeln!(
        t,
        "\n{:<width$}  {:<6}  {:>10}  {:>10}  {:<24}  identifiable",
        "parameter", "unit", "start", "estimate", "95 % interval"
    );
    for ((name, unit), (interval, start)) in names.iter().zip(units).zip(fit.intervals.iter().zip(&fit.start)) {
        let band = if interval.log_standard_error.is_finite() {
            format!("[{}, {}]", number(interval.lower), number(interval.upper))
        } else {
            "—".into()
        };
        let _ = writeln!(
            t,
            "{name:<width$}  {:<6}  {:>10}  {:>10}  {band:<24}  {}",
            unit.unwrap_or(""),
            number(*start),
            number(interval.estimate),
            match interval.set_aside {
                None => "yes",
                Some(SetAside::Flat) => "NO: flat likelihood",
                Some(SetAside::NoMaximum) => "NO: no maximum along it",
                Some(SetAside::Unknown) => "NO: the filter failed nearby",
            },
        );
    }
    let (e, e0) = (&fit.evaluation, &fit.start_evaluation);
    let _ = writeln!(t, "\nlog-likelihood: {:.3} at the estimate, {:.3} at the start", e.value(), e0.value());
    if let Some(why) = &e0.failure {
        let _ = writeln!(t, "  (the filter failed at the start values: {why})");
    }
    let band = NisBand::at_95(e.rows);
    let _ = writeln!(
        t,
        "NIS per row used: {:.4} (start: {:.4}); 95 % band for {} rows [{:.4}, {:.4}]: {}",
        e.nis_per_row(),
        e0.nis_per_row(),
        e.rows,
        band.lower,
        band.upper,
        if band.contains(e.nis_per_row()) { "inside" } else { "OUTSIDE" }
    );
    if cap.is_active() {
        let _ = writeln!(t, "rows beyond the robust cap (|ν/σ| > {}): {}", cap.threshold, e.capped_rows);
    }
    let aside = |why: SetAside| -> Vec<&str> {
        names.iter().zip(&fit.intervals).filter(|(_, i)| i.set_aside == Some(why)).map(|(n, _)| n.as_str()).collect()
    };
    let flat = aside(SetAside::Flat);
    if !flat.is_empty() {
        let _ = writeln!(
            t,
            "not identifiable from these data: {} (their 95 % interval spans more than a factor 10 either way; \
             fix them with --set and leave them out of --fit)",
            flat.join(", ")
        );
    }
    let rough: Vec<&str> = names.iter().zip(&fit.rough).filter(|(_, r)| **r).map(|(n, _)| n.as_str()).collect();
    if !rough.is_empty() {
        let _ = writeln!(
            t,
            "rough likelihood along {}: at a fifth of a standard error its curvature differs from that over a \
             10 % change by more than a factor 2 (kinks in the model); the curvature is taken over 10 %, so \
             the intervals and the convergence test there are only indicative",
            rough.join(", ")
        );
    }
    let ridge = aside(SetAside::NoMaximum);
    if !ridge.is_empty() {
        let _ = writeln!(
            t,
            "no maximum along {}: alone or with the others the curvature has the wrong sign there (a ridge or \
             saddle the search stopped on); their intervals are their own curvature's only",
            ridge.join(", ")
        );
    }
    t
}

/// The estimates as `--set NAME=VALUE` arguments, one per line.
pub fn set_lines(fit: &Fit, names: &[String]) -> String {
    names
        .iter()
        .zip(&fit.intervals)
        .map(|(name, i)| format!("--set {}\n", Assignment { name: name.clone(), value: i.estimate }))
        .collect()
}

/// The estimates as FMU start values: one `Real` per fitted parameter with its unit, its
/// interval in the description, and the units they use.
pub fn parameter_set(name: &str, source: &str, fit: &Fit, names: &[String], units: &[Option<&str>]) -> ParameterSet {
    let mut set = ParameterSet::new(name);
    let e = &fit.evaluation;
    set.description = Some(format!(
        "maximum-likelihood estimates from {source}: log-likelihood {:.3}, NIS per row used {:.4} over {} rows",
        e.value(),
        e.nis_per_row(),
        e.rows
    ));
    set.generation_tool = Some(format!("kalfmu-tune {}", env!("CARGO_PKG_VERSION")));
    for ((name, unit), interval) in names.iter().zip(units).zip(&fit.intervals) {
        let description = match interval.set_aside {
            None => format!("95 % interval [{:e}, {:e}]", interval.lower, interval.upper),
            Some(SetAside::Flat) => {
                "not identifiable from the data (flat likelihood): the value is one of many as likely".to_string()
            }
            Some(SetAside::NoMaximum) => "no maximum along it with the others: the interval is unknown".to_string(),
            Some(SetAside::Unknown) => "the filter failed near the estimate: the interval is unknown".to_string(),
        };
        // A unit is written only with its definition (the schema requires it in Units).
        let known = unit.and_then(|u| UNITS.iter().find(|k| k.name == u));
        if let Some(k) = known {
            if !set.units.iter().any(|u| u.name == k.name) {
                let [kg, m, s, rad] = k.exponents.map(i32::from);
                set.units.push(Unit { name: k.name.to_string(), exponents: [kg, m, s, 0, 0, 0, 0, rad] });
            }
        }
        set.parameters.push(Parameter {
            name: name.clone(),
            value: interval.estimate,
            kind: ValueKind::Real,
            unit: known.map(|k| k.name.to_string()),
            description: Some(description),
        });
    }
    set
}

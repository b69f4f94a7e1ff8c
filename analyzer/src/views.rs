//! A log seen through another estimate channel: the same run with that channel in the
//! place of `/estimate`, so that a log's `/estimate` and `/smoothed` (or `/prediction`)
//! are compared against its truth like any two runs.

use log_format::read::Run;
use log_format::write::ESTIMATE;
use log_format::LogError;

use crate::report::SIGMA_SUFFIX;

/// The metadata key a view records its estimate channel under (absent for `/estimate`).
pub const ESTIMATE_TOPIC: &str = "estimate_topic";

/// `run` with its channel `topic` as its estimates; `/estimate` gives the run itself.
/// Fails, naming the file, if the log has no such channel.
pub fn estimates_from(run: &Run, topic: &str) -> Result<Run, LogError> {
    if topic == ESTIMATE {
        return Ok(run.clone());
    }
    let chosen = run.channel(topic)?;
    let mut view = run.clone();
    view.channels.retain(|c| c.topic != ESTIMATE && c.topic != topic);
    let mut estimates = chosen.clone();
    estimates.topic = ESTIMATE.to_string();
    view.channels.push(estimates);
    view.metadata.insert(ESTIMATE_TOPIC.to_string(), topic.to_string());
    Ok(view)
}

/// Every run seen through each of `topics` in turn: for each run, one view per topic. With
/// several topics the views are made comparable: each keeps the estimate signals every view
/// has, over the span every view's estimates cover (a fixed-lag smoother's channel ends its
/// lag before the run, and smooths only some signals).
pub fn views(runs: &[Run], topics: &[String]) -> Result<Vec<Run>, LogError> {
    let mut views: Vec<Run> = runs
        .iter()
        .flat_map(|run| topics.iter().map(move |topic| estimates_from(run, topic)))
        .collect::<Result<_, _>>()?;
    if topics.len() > 1 {
        align(&mut views);
    }
    Ok(views)
}

/// Keeps in each run's estimates the signals all have (with each one's σ, `<name>_std`,
/// where the run has it: a baseline without σ is still compared), over the span all cover.
/// Runs that start or end at other samples (a fixed-lag smoother's channel, a baseline
/// whose first estimate is one sample later) become comparable against the same truth.
pub fn align(views: &mut [Run]) {
    let estimates = |run: &Run| run.channels.iter().position(|c| c.topic == ESTIMATE);
    let is_sigma = |name: &str| name.ends_with(SIGMA_SUFFIX);
    let mut common: Option<Vec<String>> = None;
    let (mut from, mut until) = (f64::NEG_INFINITY, f64::INFINITY);
    for view in views.iter() {
        let Some(k) = estimates(view) else { continue };
        let channel = &view.channels[k];
        let names: Vec<String> = channel.signals.iter().map(|s| s.spec.name.clone()).filter(|n| !is_sigma(n)).collect();
        common = Some(match common {
            None => names,
            Some(kept) => kept.into_iter().filter(|n| names.contains(n)).collect(),
        });
        if let (Some(first), Some(last)) = (channel.time.first(), channel.time.last()) {
            (from, until) = (from.max(*first), until.min(*last));
        }
    }
    let common = common.unwrap_or_default();
    let kept_signal = |name: &str| {
        let base = name.strip_suffix(SIGMA_SUFFIX).unwrap_or(name);
        common.iter().any(|c| c == base)
    };
    for view in views.iter_mut() {
        let Some(k) = estimates(view) else { continue };
        let channel = &mut view.channels[k];
        channel.signals.retain(|s| kept_signal(&s.spec.name));
        let keep: Vec<bool> = channel.time.iter().map(|t| (from..=until).contains(t)).collect();
        let kept = |values: &[f64]| values.iter().zip(&keep).filter(|(_, k)| **k).map(|(v, _)| *v).collect();
        channel.time = kept(&channel.time);
        for signal in &mut channel.signals {
            signal.values = kept(&signal.values);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use log_format::read::{Channel, Signal};
    use log_format::write::{SignalSpec, SMOOTHED, TRUTH};
    use std::collections::BTreeMap;

    fn channel(topic: &str, value: f64) -> Channel {
        Channel {
            topic: topic.to_string(),
            time: vec![0.0, 1.0],
            signals: vec![Signal { spec: SignalSpec::new("F", "N", ""), values: vec![value, value] }],
        }
    }

    #[test]
    fn a_view_puts_the_chosen_channel_in_the_place_of_the_estimates() {
        let run = Run {
            file: "run.mcap".into(),
            metadata: BTreeMap::from([("filter".to_string(), "SRCKF".to_string())]),
            channels: vec![channel(TRUTH, 1.0), channel(ESTIMATE, 2.0), channel(SMOOTHED, 3.0)],
            skipped: Vec::new(),
            damage: None,
        };
        let view = estimates_from(&run, SMOOTHED).unwrap();
        assert_eq!(view.channel(ESTIMATE).unwrap().signals[0].values, [3.0, 3.0]);
        assert_eq!(view.channel(TRUTH).unwrap().signals[0].values, [1.0, 1.0]);
        assert!(view.channel(SMOOTHED).is_err(), "the chosen channel appears once, as the estimates");
        assert_eq!(view.metadata[ESTIMATE_TOPIC], SMOOTHED);
        assert_eq!(estimates_from(&run, ESTIMATE).unwrap(), run);
        assert!(estimates_from(&run, "/nowhere").is_err());
        assert_eq!(views(&[run.clone(), run], &[ESTIMATE.into(), SMOOTHED.into()]).unwrap().len(), 4);
    }

    #[test]
    fn views_of_several_channels_keep_the_signals_and_the_span_all_have() {
        let mut smoothed = channel(SMOOTHED, 3.0);
        smoothed.time.pop();
        smoothed.signals[0].values.pop();
        let mut estimate = channel(ESTIMATE, 2.0);
        estimate.signals.push(Signal { spec: SignalSpec::new("nis", "1", ""), values: vec![1.0, 1.0] });
        let run = Run {
            file: "run.mcap".into(),
            metadata: BTreeMap::new(),
            channels: vec![channel(TRUTH, 1.0), estimate, smoothed],
            skipped: Vec::new(),
            damage: None,
        };
        let aligned = views(&[run], &[ESTIMATE.into(), SMOOTHED.into()]).unwrap();
        for view in &aligned {
            let e = view.channel(ESTIMATE).unwrap();
            assert_eq!(e.time, [0.0], "the span both cover");
            assert_eq!(
                e.signals.iter().map(|s| s.spec.name.as_str()).collect::<Vec<_>>(),
                ["F"],
                "the signals both have"
            );
        }
        assert_eq!(aligned[1].channel(ESTIMATE).unwrap().signals[0].values, [3.0]);
    }

    #[test]
    fn aligned_runs_keep_each_ones_sigma_of_a_common_signal() {
        let with_sigma = |values: Vec<f64>, time: Vec<f64>| Channel {
            topic: ESTIMATE.to_string(),
            time,
            signals: vec![
                Signal { spec: SignalSpec::new("F", "N", ""), values: values.clone() },
                Signal { spec: SignalSpec::new("F_std", "N", ""), values },
            ],
        };
        let run = |estimate: Channel| Run {
            file: "run.mcap".into(),
            metadata: BTreeMap::new(),
            channels: vec![channel(TRUTH, 1.0), estimate],
            skipped: Vec::new(),
            damage: None,
        };
        let filter = run(with_sigma(vec![2.0, 2.0], vec![0.0, 1.0]));
        // A baseline without σ, its first estimate one sample later.
        let mut baseline = run(channel(ESTIMATE, 4.0));
        let estimate = &mut baseline.channels[1];
        (estimate.time, estimate.signals[0].values) = (vec![1.0], vec![4.0]);
        let mut runs = [filter, baseline];
        align(&mut runs);
        let names = |run: &Run| -> Vec<String> {
            run.channel(ESTIMATE).unwrap().signals.iter().map(|s| s.spec.name.clone()).collect()
        };
        assert_eq!(names(&runs[0]), ["F", "F_std"], "the filter keeps its σ");
        assert_eq!(names(&runs[1]), ["F"]);
        assert_eq!(runs[0].channel(ESTIMATE).unwrap().time, [1.0], "from the baseline's first estimate");
        assert_eq!(runs[0].channel(TRUTH).unwrap().time, [0.0, 1.0], "the truth is left whole");
    }
}

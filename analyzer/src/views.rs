//! A log seen through another estimate channel: the same run with that channel in the
//! place of `/estimate`, so that a log's `/estimate` and `/smoothed` (or `/prediction`)
//! are compared against its truth like any two runs.

use log_format::read::Run;
use log_format::write::ESTIMATE;
use log_format::LogError;

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

/// Every run seen through each of `topics` in turn: for each run, one view per topic.
pub fn views(runs: &[Run], topics: &[String]) -> Result<Vec<Run>, LogError> {
    runs.iter().flat_map(|run| topics.iter().map(move |topic| estimates_from(run, topic))).collect()
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
}

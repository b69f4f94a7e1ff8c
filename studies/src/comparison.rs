//! What every study's part of `reproduce` shares: a case's runs compared and recorded, an
//! FMU's outputs set against the same filter in-process, where the logs go, and the table's
//! figures written as JSON.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use analyzer::compare::{compare_runs, Comparison};
use analyzer::report::Options;
use analyzer::rrd::write_rrd;
use anyhow::Context;
use log_format::read::{Channel, Run};

/// One case's runs compared: the comparison, written as `<stem>.json` and as the Rerun
/// recording `<stem>.rrd`, whose path is returned with it.
pub fn compare_case<'a>(
    runs: &'a [Run],
    options: &Options,
    stem: &Path,
) -> Result<(Comparison<'a>, PathBuf), log_format::LogError> {
    let comparison = compare_runs(runs, options)?;
    let recording = stem.with_extension("rrd");
    comparison.write_json(&stem.with_extension("json"))?;
    write_rrd(&comparison, runs, &recording)?;
    Ok((comparison, recording))
}

/// The signals `names` of `channel`, one row per sample.
pub fn rows_of<const N: usize>(channel: &Channel, names: [&str; N]) -> anyhow::Result<Vec<[f64; N]>> {
    let columns: Vec<&[f64]> = names
        .iter()
        .map(|n| {
            channel.signal(n).map(|s| s.values.as_slice()).with_context(|| format!("{} has no {n}", channel.topic))
        })
        .collect::<anyhow::Result<_>>()?;
    Ok((0..channel.time.len()).map(|k| std::array::from_fn(|i| columns[i][k])).collect())
}

/// The largest difference between two runs' rows, entry by entry: how far an FMU's
/// outputs are from the same filter in-process. An error if their lengths differ.
pub fn largest_difference<const N: usize>(a: &[[f64; N]], b: &[[f64; N]]) -> anyhow::Result<f64> {
    anyhow::ensure!(a.len() == b.len(), "{} samples against {}", a.len(), b.len());
    Ok(a.iter().zip(b).flat_map(|(x, y)| x.iter().zip(y).map(|(u, v)| (u - v).abs())).fold(0.0, f64::max))
}

/// The log of one filter's run of a case: `<stem>_<filter>.mcap`, e.g. `weld_srckf.mcap`.
pub fn log_path(stem: &Path, kind: estimator::FilterKind) -> PathBuf {
    let case = stem.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    stem.with_file_name(format!("{case}_{}.mcap", kind.name().to_lowercase().replace('-', "")))
}

/// The name of the file in each study's output directory that holds the figures of the
/// table `reproduce` prints (`out/s1/table.json`, …; see the `kalfmu reproduce` docs).
pub const TABLE_FILE: &str = "table.json";

/// Writes a study's table, `table`, as pretty-printed JSON to [`TABLE_FILE`] in `dir`;
/// returns the file's path. A figure that is not a number (NaN, ±∞) is written `null`.
pub fn write_table(dir: &Path, table: &impl serde::Serialize) -> anyhow::Result<PathBuf> {
    let path = dir.join(TABLE_FILE);
    let mut text = serde_json::to_string_pretty(table).context("cannot serialise the table")?;
    text.push('\n');
    std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(path)
}

/// The `units` object of a table: each dimensional field's name and its unit. Fields it
/// does not list are dimensionless (correlations, fractions) or counts.
pub fn units(pairs: &[(&'static str, &'static str)]) -> BTreeMap<&'static str, &'static str> {
    pairs.iter().copied().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_is_written_to_table_json_in_its_directory_with_nan_as_null() {
        let dir = std::env::temp_dir().join(format!("kalfmu-write-table-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let table = serde_json::json!({ "correlation": 0.5, "coverage": f64::NAN });
        let path = write_table(&dir, &table).unwrap();
        assert_eq!(path, dir.join("table.json"));
        let written: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(written, serde_json::json!({ "correlation": 0.5, "coverage": null }));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

//! A log cut short, as a writer that dies leaves it, is read up to the cut: every
//! complete message before it and nothing else, with a warning saying what was
//! recovered. A file that is not MCAP says so. Never a panic, never a wrong number.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use analyzer::report::{analyse, Options};
use log_format::read::{read_log, Run};
use log_format::write::{LogWriter, SignalSpec, ESTIMATE, MEASUREMENTS, TRUTH};
use log_format::LogError;

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kalfmu-analyzer-recovery-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// 30 000 samples at 1 kHz on three channels: about 2.6 MB of messages, four chunks.
fn write_long_run(path: &Path) {
    let metadata = BTreeMap::from([("study".to_string(), "recovery".to_string())]);
    let mut w = LogWriter::create(path, &metadata).unwrap();
    let m = w.add_channel(MEASUREMENTS, &[SignalSpec::new("a", "m/s2", "acceleration")]).unwrap();
    let t = w.add_channel(TRUTH, &[SignalSpec::new("F", "N", "true load")]).unwrap();
    let e = w
        .add_channel(ESTIMATE, &[SignalSpec::new("F", "N", "estimate"), SignalSpec::new("F_std", "N", "deviation")])
        .unwrap();
    for k in 0..30_000 {
        let time = k as f64 * 1e-3;
        let truth = 10.0 * (2.0 * std::f64::consts::PI * 1.5 * time).sin();
        w.write(m, time, &[truth / 8.0]).unwrap();
        w.write(t, time, &[truth]).unwrap();
        w.write(e, time, &[truth + 0.01 * ((k * 7919 % 13) as f64 - 6.0), 0.1]).unwrap();
    }
    w.finish().unwrap();
}

/// Every recovered channel is an exact prefix of the whole log's channel.
fn assert_prefix_of(part: &Run, whole: &Run, cut: usize) {
    for c in &part.channels {
        let full = whole.channel(&c.topic).unwrap();
        let n = c.time.len();
        assert!(n <= full.time.len(), "cut at {cut}: {} has more messages than the whole log", c.topic);
        assert_eq!(c.time[..], full.time[..n], "cut at {cut}: times of {}", c.topic);
        for (s, f) in c.signals.iter().zip(&full.signals) {
            assert_eq!(s.spec, f.spec, "cut at {cut}");
            let same = s.values.iter().zip(&f.values[..n]).all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "cut at {cut}: values of {}.{}", c.topic, s.spec.name);
        }
    }
}

fn messages(run: &Run) -> usize {
    run.channels.iter().map(|c| c.time.len()).sum()
}

#[test]
fn a_log_cut_at_any_byte_gives_its_complete_prefix_or_a_clear_error() {
    let path = temp("whole.mcap");
    write_long_run(&path);
    let whole = read_log(&path).unwrap();
    assert!(whole.damage.is_none() && whole.recovery_warning().is_none());
    let bytes = std::fs::read(&path).unwrap();
    let cut_path = temp("cut.mcap");
    let (mut previous, mut recovered_inside_a_chunk, mut reports) = (0, false, 0);
    // Every offset near the start and the end, and a prime stride through the middle.
    let offsets = (0..200).chain((200..bytes.len() - 200).step_by(4999)).chain(bytes.len() - 200..=bytes.len());
    for cut in offsets {
        std::fs::write(&cut_path, &bytes[..cut]).unwrap();
        match read_log(&cut_path) {
            Ok(run) => {
                assert_prefix_of(&run, &whole, cut);
                let n = messages(&run);
                assert!(n >= previous, "cut at {cut}: {n} messages, fewer than a shorter cut's {previous}");
                // More messages than the last complete chunk held: read from the cut chunk.
                recovered_inside_a_chunk |= n > previous && previous > 0 && run.damage.is_some();
                previous = n;
                if let Some(warning) = run.recovery_warning() {
                    assert!(warning.contains("cut.mcap") && warning.contains("/truth"), "{warning}");
                }
                match analyse(&run, &Options::default()) {
                    Ok(report) => {
                        let p = &report.pairs[0];
                        assert_eq!(
                            p.samples,
                            run.channel(TRUTH).unwrap().time.len().min(run.channel(ESTIMATE).unwrap().time.len())
                        );
                        reports += 1;
                    }
                    Err(e) => assert!(
                        matches!(e, LogError::MissingChannel { .. } | LogError::Analysis { .. }),
                        "cut at {cut}: {e}"
                    ),
                }
            }
            Err(e) => {
                assert!(matches!(e, LogError::NotMcap { .. } | LogError::Truncated { .. }), "cut at {cut}: {e}");
                assert!(e.to_string().contains("cut.mcap"), "{e}");
                assert_eq!(previous, 0, "cut at {cut}: an error after a shorter cut recovered messages: {e}");
            }
        }
    }
    assert_eq!(previous, messages(&whole), "the whole file reads whole");
    assert!(recovered_inside_a_chunk, "some cut inside a chunk recovers that chunk's complete messages");
    assert!(reports > 100, "most cuts give a report ({reports})");
}

#[test]
fn a_file_that_is_not_mcap_says_exactly_that() {
    for (name, content) in [("text.mcap", &b"time,F\n0,1.5\n0.01,1.6\n"[..]), ("empty.mcap", &b""[..])] {
        let path = temp(name);
        std::fs::write(&path, content).unwrap();
        let err = read_log(&path).unwrap_err();
        assert!(matches!(err, LogError::NotMcap { .. }), "{err}");
        assert_eq!(
            err.to_string(),
            format!("{}: not an MCAP file (it does not start with the MCAP magic bytes)", path.display())
        );
    }
}

#[test]
fn the_command_warns_with_what_was_recovered_then_reports() {
    let path = temp("crashed.mcap");
    write_long_run(&path);
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_analyzer")).arg("report").arg(&path).output().unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.starts_with("warning: ") && stderr.contains("the log is cut short at byte"), "{stderr}");
    for topic in [MEASUREMENTS, TRUTH, ESTIMATE] {
        assert!(stderr.contains(&format!("  {topic}: ")), "{stderr}");
    }
    assert!(stdout.contains("corr"), "{stdout}");
    let garbage = temp("garbage.mcap");
    std::fs::write(&garbage, "not a log at all\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_analyzer")).arg("report").arg(&garbage).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not an MCAP file"));
}

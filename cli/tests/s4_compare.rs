//! `kalfmu s4-compare` prints, per seed, the four estimators' speed and position
//! errors and the detections per fault kind, and its shards split the seeds.

fn compare(args: &[&str]) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_kalfmu")).arg("s4-compare").args(args).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

/// The numbers of the row that starts with `name` in `block`.
fn row(block: &str, name: &str) -> Vec<f64> {
    let line = block.lines().find(|l| l.starts_with(name)).unwrap_or_else(|| panic!("no row {name}:\n{block}"));
    line[name.len()..].split_whitespace().filter_map(|v| v.trim_end_matches('%').parse().ok()).collect()
}

#[test]
fn each_seed_has_its_table_and_the_shards_split_the_seeds() {
    let all = compare(&["--seeds", "2"]);
    let (first, second) = (compare(&["--seeds", "2", "--shard", "1/2"]), compare(&["--seeds", "2", "--shard", "2/2"]));
    assert!(first.contains("seed 1:") && !first.contains("seed 2:"), "{first}");
    assert!(second.contains("seed 2:") && !second.contains("seed 1:"), "{second}");
    let block = |text: &str, seed: u64| -> String {
        let start = text.find(&format!("seed {seed}:")).unwrap();
        text[start..].split("\nseed ").next().unwrap().trim_end().to_string()
    };
    assert_eq!(block(&all, 1), block(&first, 1));
    assert_eq!(block(&all, 2), block(&second, 2));
    for seed in [1, 2] {
        let b = block(&all, seed);
        // mean |e|, (vs raw), max |e|, speed range, e range, position max, in band.
        let raw = row(&b, "raw average");
        let ours = row(&b, "ours");
        assert_eq!((raw.len(), ours.len()), (6, 7), "{b}");
        assert!(ours[0] < raw[0] && ours[2] < raw[1], "{b}");
        // Detected never exceeds injected, for both.
        for kind in ["dropout", "resend", "spike", "slot slip", "offset"] {
            let r = row(&b, kind);
            assert!(r.len() == 3 && r[1] <= r[0] && r[2] <= r[0], "{kind}: {b}");
        }
        assert_eq!(row(&b, "false alarms").len(), 2, "{b}");
    }
}

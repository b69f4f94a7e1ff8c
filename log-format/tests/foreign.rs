//! Logs other tools write are read with the format's rules: `json` channels (Python's
//! `mcap`, Foxglove) and `cdr` channels with `ros2msg` schemas (ROS 2 bags), each number of
//! a message a signal named by its path, the time its `log_time`. Messages here are
//! hand-made bytes, so each test states exactly what a writer puts in the file.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use log_format::read::{read_log, Channel, Run};
use log_format::write::{SignalSpec, ESTIMATE, TRUTH};
use log_format::LogError;

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kalfmu-log-format-foreign-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// A channel of a log: topic, message encoding, schema (name, encoding, text; `None`: no
/// schema) and its messages (time in ns, bytes).
struct Topic<'a> {
    topic: &'a str,
    message_encoding: &'a str,
    schema: Option<(&'a str, &'a str, &'a str)>,
    messages: Vec<(u64, Vec<u8>)>,
}

fn write_log(path: &Path, topics: &[Topic]) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new().create(file).unwrap();
    let mut ids = Vec::new();
    for t in topics {
        let schema =
            t.schema.map_or(0, |(name, encoding, text)| w.add_schema(name, encoding, text.as_bytes()).unwrap());
        ids.push(w.add_channel(schema, t.topic, t.message_encoding, &BTreeMap::new()).unwrap());
    }
    for (t, &id) in topics.iter().zip(&ids) {
        for (sequence, (time, data)) in t.messages.iter().enumerate() {
            let header = mcap::records::MessageHeader {
                channel_id: id,
                sequence: sequence as u32,
                log_time: *time,
                publish_time: *time,
            };
            w.write_to_known_channel(&header, data).unwrap();
        }
    }
    w.finish().unwrap();
}

fn names(channel: &Channel) -> Vec<&str> {
    channel.signals.iter().map(|s| s.spec.name.as_str()).collect()
}

fn values<'a>(channel: &'a Channel, name: &str) -> &'a [f64] {
    &channel.signal(name).unwrap_or_else(|| panic!("no signal {name} in {:?}", names(channel))).values
}

/// Bit-for-bit equality, so that NaN equals NaN.
fn assert_bits(actual: &[f64], expected: &[f64]) {
    let same = actual.len() == expected.len() && actual.iter().zip(expected).all(|(a, b)| a.to_bits() == b.to_bits());
    assert!(same, "{actual:?} != {expected:?}");
}

const JSON_SCHEMA: &str = r#"{
  "type": "object",
  "properties": {
    "F": {"type": "number", "description": "[N] estimated load"},
    "label": {"type": "string"},
    "ok": {"type": "boolean"},
    "pos": {"type": "object", "properties": {"x": {"type": "number", "unit": "m"}}},
    "q": {"type": "array", "items": {"type": "number"}},
    "F_std": {"type": ["number", "null"]},
    "unused": {"type": "number", "description": "declared, but in no message"}
  }
}"#;

fn json_log(name: &str, messages: &[&str]) -> PathBuf {
    let path = temp(name);
    let messages = messages.iter().enumerate().map(|(k, m)| (k as u64 * 10_000_000, m.as_bytes().to_vec())).collect();
    let schema = Some(("Estimate", "jsonschema", JSON_SCHEMA));
    write_log(&path, &[Topic { topic: ESTIMATE, message_encoding: "json", schema, messages }]);
    path
}

#[test]
fn json_signals_follow_the_schema_with_its_units_where_messages_have_them_and_missing_values_are_nan() {
    let path = json_log(
        "json.mcap",
        &[
            r#"{"F": 1.5, "label": "a", "ok": true, "pos": {"x": 2}, "q": [1, 2], "F_std": 0.1}"#,
            r#"{"q": [3, 4, 5], "pos": {"x": -1}, "F": null, "ok": false, "extra": 7}"#,
            r#"{"F": NaN, "F_std": Infinity, "label": "NaN", "pos": {"x": -Infinity}}"#,
        ],
    );
    let run = read_log(&path).unwrap();
    let e = run.channel(ESTIMATE).unwrap();
    // The schema's numbers first, in its order (`unused` is in no message: no signal);
    // then what the messages add, in theirs.
    assert_eq!(names(e), ["F", "ok", "pos.x", "F_std", "q[0]", "q[1]", "q[2]", "extra"]);
    assert_eq!(e.signal("F").unwrap().spec, SignalSpec::new("F", "N", "estimated load"));
    assert_eq!(e.signal("pos.x").unwrap().spec.unit, "m");
    assert_eq!(e.time, [0.0, 0.01, 0.02]);
    let nan = f64::NAN;
    assert_bits(values(e, "F"), &[1.5, nan, nan]);
    assert_bits(values(e, "ok"), &[1.0, 0.0, nan]);
    assert_bits(values(e, "pos.x"), &[2.0, -1.0, f64::NEG_INFINITY]);
    assert_bits(values(e, "F_std"), &[0.1, nan, f64::INFINITY]);
    assert_bits(values(e, "q[2]"), &[nan, 5.0, nan]);
    assert_bits(values(e, "extra"), &[nan, 7.0, nan]);
}

#[test]
fn a_json_channel_without_a_schema_takes_its_signals_from_its_messages() {
    let path = temp("schemaless.mcap");
    let messages =
        vec![(0, br#"{"x": 1, "y": {"z": 2.5}}"#.to_vec()), (1_000_000, br#"{"y": {"z": 3}, "x": 4}"#.to_vec())];
    write_log(&path, &[Topic { topic: TRUTH, message_encoding: "json", schema: None, messages }]);
    let run = read_log(&path).unwrap();
    let t = run.channel(TRUTH).unwrap();
    assert_eq!(names(t), ["x", "y.z"]);
    assert_bits(values(t, "x"), &[1.0, 4.0]);
    assert_bits(values(t, "y.z"), &[2.5, 3.0]);
}

#[test]
fn a_message_that_is_not_json_is_named_with_its_channel_and_time() {
    let path = json_log("bad_json.mcap", &[r#"{"F": 1}"#, r#"{"F": 2"#]);
    let err = read_log(&path).unwrap_err().to_string();
    assert!(err.contains("channel /estimate at t = 0.01 s: not JSON: "), "{err}");
    let path = json_log("not_an_object.mcap", &["[1, 2]"]);
    let err = read_log(&path).unwrap_err().to_string();
    assert!(
        err.contains("channel /estimate at t = 0 s: not JSON: invalid type: sequence, expected a JSON object"),
        "{err}"
    );
}

/// CDR as ROS 2 writes it: a 4-byte encapsulation header, then each primitive aligned to its
/// size, counted from the end of the header.
struct Cdr {
    bytes: Vec<u8>,
    little: bool,
}

impl Cdr {
    fn new(little: bool) -> Self {
        Self { bytes: vec![0, u8::from(little), 0, 0], little }
    }

    fn put(&mut self, le: &[u8], be: &[u8]) -> &mut Self {
        while !(self.bytes.len() - 4).is_multiple_of(le.len()) {
            self.bytes.push(0);
        }
        self.bytes.extend_from_slice(if self.little { le } else { be });
        self
    }

    fn f64(&mut self, v: f64) -> &mut Self {
        self.put(&v.to_le_bytes(), &v.to_be_bytes())
    }

    fn f32(&mut self, v: f32) -> &mut Self {
        self.put(&v.to_le_bytes(), &v.to_be_bytes())
    }

    fn i32(&mut self, v: i32) -> &mut Self {
        self.put(&v.to_le_bytes(), &v.to_be_bytes())
    }

    fn u32(&mut self, v: u32) -> &mut Self {
        self.put(&v.to_le_bytes(), &v.to_be_bytes())
    }

    fn u8(&mut self, v: u8) -> &mut Self {
        self.put(&[v], &[v])
    }

    fn string(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32 + 1);
        self.bytes.extend_from_slice(s.as_bytes());
        self.bytes.push(0);
        self
    }

    fn done(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.bytes)
    }
}

const FLAT: &str = "\
# A flat message, as a user would log it
float64 x  # [m] position
float32 v
int32 n
uint8 b
bool flag
float64[2] p
float64[] s  # [N] samples
string name
int32 LIMIT=10
";

fn flat_message(little: bool, s: &[f64]) -> Vec<u8> {
    let mut m = Cdr::new(little);
    m.f64(1.25).f32(-0.5).i32(-7).u8(200).u8(1).f64(3.0).f64(4.0).u32(s.len() as u32);
    for &v in s {
        m.f64(v);
    }
    m.string("probe").done()
}

#[test]
fn a_flat_ros2_message_is_read_in_both_byte_orders() {
    for little in [true, false] {
        let path = temp("flat.mcap");
        let messages = vec![(0, flat_message(little, &[9.0])), (500_000_000, flat_message(little, &[10.0, 11.0]))];
        let schema = Some(("kalfmu_msgs/msg/Flat", "ros2msg", FLAT));
        write_log(&path, &[Topic { topic: TRUTH, message_encoding: "cdr", schema, messages }]);
        let run = read_log(&path).unwrap();
        let t = run.channel(TRUTH).unwrap();
        assert_eq!(names(t), ["x", "v", "n", "b", "flag", "p[0]", "p[1]", "s[0]", "s[1]"], "little-endian: {little}");
        assert_eq!(t.signal("x").unwrap().spec, SignalSpec::new("x", "m", "position"));
        assert_eq!(t.time, [0.0, 0.5]);
        assert_bits(values(t, "x"), &[1.25, 1.25]);
        assert_bits(values(t, "v"), &[-0.5, -0.5]);
        assert_bits(values(t, "n"), &[-7.0, -7.0]);
        assert_bits(values(t, "b"), &[200.0, 200.0]);
        assert_bits(values(t, "flag"), &[1.0, 1.0]);
        assert_bits(values(t, "p[1]"), &[4.0, 4.0]);
        assert_bits(values(t, "s[0]"), &[9.0, 10.0]);
        assert_bits(values(t, "s[1]"), &[f64::NAN, 11.0]);
        assert_eq!(t.signal("s[1]").unwrap().spec, SignalSpec::new("s[1]", "N", "samples"));
    }
}

const STAMPED: &str = "\
std_msgs/Header header
float64 load
geometry_msgs/Point position
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
";

#[test]
fn a_header_stamp_is_not_a_signal_and_nested_messages_are_flattened() {
    let path = temp("stamped.mcap");
    let message = |k: u32| {
        let mut m = Cdr::new(true);
        // The stamp disagrees with log_time on purpose: the time is the log_time.
        m.i32(1_700_000_000).u32(k).string("base_link").f64(f64::from(k) * 0.5);
        m.f64(1.0).f64(2.0).f64(-3.0).done()
    };
    let messages = (0..3).map(|k| (u64::from(k) * 100_000_000, message(k))).collect();
    let schema = Some(("kalfmu_msgs/msg/Stamped", "ros2msg", STAMPED));
    write_log(&path, &[Topic { topic: ESTIMATE, message_encoding: "cdr", schema, messages }]);
    let run = read_log(&path).unwrap();
    let e = run.channel(ESTIMATE).unwrap();
    assert_eq!(names(e), ["load", "position.x", "position.y", "position.z"]);
    assert_eq!(e.time, [0.0, 0.1, 0.2]);
    assert_bits(values(e, "load"), &[0.0, 0.5, 1.0]);
    assert_bits(values(e, "position.z"), &[-3.0; 3]);
}

#[test]
fn a_cdr_message_shorter_than_its_schema_or_a_schema_with_an_unknown_type_is_named() {
    let path = temp("short_cdr.mcap");
    let mut short = flat_message(true, &[1.0]);
    short.truncate(20);
    let messages = vec![(0, flat_message(true, &[1.0])), (250_000_000, short)];
    let schema = Some(("kalfmu_msgs/msg/Flat", "ros2msg", FLAT));
    write_log(&path, &[Topic { topic: TRUTH, message_encoding: "cdr", schema, messages }]);
    let err = read_log(&path).unwrap_err().to_string();
    assert!(err.contains("channel /truth at t = 0.25 s: 20 bytes: the message ends before its fields do"), "{err}");

    let path = temp("unknown_type.mcap");
    let schema = Some(("kalfmu_msgs/msg/Odd", "ros2msg", "float64 x\nkalfmu_msgs/Missing m\n"));
    write_log(&path, &[Topic { topic: TRUTH, message_encoding: "cdr", schema, messages: vec![(0, vec![0, 1, 0, 0])] }]);
    let err = read_log(&path).unwrap_err();
    assert!(matches!(err, LogError::Schema { .. }), "{err}");
    assert!(err.to_string().contains("field 'm' is a kalfmu_msgs/Missing, which the schema does not define"), "{err}");
}

#[test]
fn a_channel_in_an_unknown_encoding_is_skipped_with_its_reason_unless_it_is_all_there_is() {
    let protobuf = |topic| Topic {
        topic,
        message_encoding: "protobuf",
        schema: Some(("pkg.Msg", "protobuf", "")),
        messages: vec![(0, vec![1, 2, 3])],
    };
    let path = temp("protobuf_only.mcap");
    write_log(&path, &[protobuf("/imu")]);
    let err = read_log(&path).unwrap_err();
    assert!(matches!(err, LogError::Unreadable { .. }), "{err}");
    assert!(err.to_string().contains("no channel can be read: /imu: message encoding 'protobuf' is not read"), "{err}");

    let path = temp("protobuf_and_json.mcap");
    let json =
        Topic { topic: TRUTH, message_encoding: "json", schema: None, messages: vec![(0, br#"{"F": 1}"#.to_vec())] };
    write_log(&path, &[protobuf("/imu"), json]);
    let run: Run = read_log(&path).unwrap();
    assert_eq!(run.channels.len(), 1);
    let warnings = run.skip_warnings();
    assert_eq!(warnings.len(), 1);
    assert!(warnings[0].ends_with("channel /imu is skipped: message encoding 'protobuf' is not read (the reader reads ros1, json and cdr; docs/log-format.md)"), "{}", warnings[0]);
    let err = run.channel("/imu").unwrap_err().to_string();
    assert!(err.contains("the log has: /truth; skipped /imu: message encoding 'protobuf'"), "{err}");
}

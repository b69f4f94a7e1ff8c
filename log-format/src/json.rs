//! JSON channels: message encoding `json`, schema encoding `jsonschema` (or no schema), as
//! Python's `mcap` writer and Foxglove log them.
//!
//! Signals are the numbers of the message: a property of type `number`, `integer` or
//! `boolean` (1 or 0) is a signal named by its key; nested objects are flattened with `.`
//! (`position.x`) and array elements named by their index (`q[0]`). The schema's
//! properties give the order, and their `unit` (a kalfmu extension) or a description
//! starting `[unit]` the unit, as the format's comments do. A key the schema does not
//! declare becomes a signal when a message first has a number there, and a property that
//! no message of the channel has a number for is none (one schema often serves several
//! topics); strings are not signals; `null` or a missing key is a missing value (NaN). The bare `NaN`, `Infinity`
//! and `-Infinity` that Python's `json.dumps` writes are read as those values.
//!
//! Messages are parsed straight into the signals' slots (no JSON tree per message): the
//! keys are matched against the schema's, trying first the key that followed the previous.

use std::fmt;

use serde::de::{DeserializeSeed, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;

use crate::decode::{Row, MAX_ELEMENTS};
use crate::write::{unit_and_description, SignalSpec};

/// A JSON channel's decoder: the tree of its signals' slots.
#[derive(Debug)]
pub struct JsonDecoder {
    root: Node,
}

/// Where a value of the message goes.
#[derive(Debug)]
enum Node {
    /// Not met yet: becomes a number, an object or an array when a message has one here.
    New(String),
    /// A signal's slot.
    Number(usize),
    /// An object's keys, in schema order then in the order messages brought them.
    Object {
        /// The path of the object (`""` at the top).
        path: String,
        /// Key and node.
        fields: Vec<(String, Node)>,
    },
    /// An array's elements.
    Array {
        /// The path of the array.
        path: String,
        /// One node per index met so far.
        items: Vec<Node>,
    },
    /// Not a signal (a string).
    Ignored,
}

impl JsonDecoder {
    /// The decoder of channels with this `jsonschema` (empty: no schema), and the signals
    /// it declares.
    pub fn new(schema: &[u8]) -> Result<(Self, Vec<SignalSpec>), String> {
        let mut signals = Vec::new();
        if schema.iter().all(u8::is_ascii_whitespace) {
            return Ok((Self { root: Node::Object { path: String::new(), fields: Vec::new() } }, signals));
        }
        let schema: SchemaNode =
            serde_json::from_slice(schema).map_err(|e| format!("the JSON schema is not JSON: {e}"))?;
        let root = compile(&schema, String::new(), &mut signals);
        match root {
            Node::Object { .. } => Ok((Self { root }, signals)),
            Node::New(_) => Ok((Self { root: Node::Object { path: String::new(), fields: Vec::new() } }, signals)),
            _ => Err("the JSON schema does not describe an object".into()),
        }
    }

    /// Reads one message into `row`.
    pub fn decode(&mut self, data: &[u8], row: &mut Row) -> Result<(), String> {
        match parse(&mut self.root, data, row) {
            Ok(()) => Ok(()),
            // Slots a first attempt added stay in `row`: the second sets them again.
            Err(e) => match quote_non_finite(data) {
                Some(quoted) => parse(&mut self.root, &quoted, row).map_err(|e| format!("not JSON: {e}")),
                None => Err(format!("not JSON: {e}")),
            },
        }
    }
}

fn parse(root: &mut Node, data: &[u8], row: &mut Row) -> Result<(), serde_json::Error> {
    let mut de = serde_json::Deserializer::from_slice(data);
    de.deserialize_map(NodeSeed { node: root, row })?;
    de.end()
}

/// `data` with the bare `NaN`, `Infinity` and `-Infinity` outside strings quoted (`None` if
/// there are none), so that it parses as JSON.
fn quote_non_finite(data: &[u8]) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(data.len() + 16);
    let (mut in_string, mut escaped, mut changed) = (false, false, false);
    let mut at = 0;
    while at < data.len() {
        let b = data[at];
        if in_string {
            match (escaped, b) {
                (true, _) => escaped = false,
                (false, b'\\') => escaped = true,
                (false, b'"') => in_string = false,
                _ => {}
            }
        } else if b == b'"' {
            in_string = true;
        } else if let Some(token) =
            [&b"-Infinity"[..], b"Infinity", b"NaN"].into_iter().find(|t| data[at..].starts_with(t))
        {
            out.push(b'"');
            out.extend_from_slice(token);
            out.push(b'"');
            at += token.len();
            changed = true;
            continue;
        }
        out.push(b);
        at += 1;
    }
    changed.then_some(out)
}

/// The value of a string that stands for a non-finite number.
fn non_finite(text: &str) -> Option<f64> {
    match text {
        "NaN" | "nan" => Some(f64::NAN),
        "Infinity" | "inf" => Some(f64::INFINITY),
        "-Infinity" | "-inf" => Some(f64::NEG_INFINITY),
        _ => None,
    }
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

/// Reads one value into the node it belongs to.
struct NodeSeed<'a> {
    node: &'a mut Node,
    row: &'a mut Row,
}

impl NodeSeed<'_> {
    fn number(self, value: f64) {
        match self.node {
            Node::Number(slot) => self.row.values[*slot] = value,
            Node::New(path) => {
                let slot = self.row.add(SignalSpec::new(path, "", ""));
                self.row.values[slot] = value;
                *self.node = Node::Number(slot);
            }
            _ => {}
        }
    }
}

impl<'de> DeserializeSeed<'de> for NodeSeed<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        deserializer.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for NodeSeed<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON object")
    }

    fn visit_bool<E>(self, v: bool) -> Result<(), E> {
        self.number(if v { 1.0 } else { 0.0 });
        Ok(())
    }

    fn visit_i64<E>(self, v: i64) -> Result<(), E> {
        self.number(v as f64);
        Ok(())
    }

    fn visit_u64<E>(self, v: u64) -> Result<(), E> {
        self.number(v as f64);
        Ok(())
    }

    fn visit_f64<E>(self, v: f64) -> Result<(), E> {
        self.number(v);
        Ok(())
    }

    fn visit_str<E>(self, v: &str) -> Result<(), E> {
        match non_finite(v) {
            Some(value) => self.number(value),
            None if matches!(self.node, Node::New(_)) => *self.node = Node::Ignored,
            None => {}
        }
        Ok(())
    }

    fn visit_unit<E>(self) -> Result<(), E> {
        Ok(())
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        if let Node::New(path) = self.node {
            *self.node = Node::Object { path: std::mem::take(path), fields: Vec::new() };
        }
        let Node::Object { path, fields } = self.node else {
            while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
            return Ok(());
        };
        let mut next = 0;
        while let Some(key) = map.next_key_seed(KeySeed { fields: &fields[..], next })? {
            let index = match key {
                Key::Found(index) => index,
                Key::New(key) => {
                    fields.push((key.clone(), Node::New(join(path, &key))));
                    fields.len() - 1
                }
            };
            next = index + 1;
            map.next_value_seed(NodeSeed { node: &mut fields[index].1, row: self.row })?;
        }
        Ok(())
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        if let Node::New(path) = self.node {
            *self.node = Node::Array { path: std::mem::take(path), items: Vec::new() };
        }
        let Node::Array { path, items } = self.node else {
            while seq.next_element::<IgnoredAny>()?.is_some() {}
            return Ok(());
        };
        for index in 0..MAX_ELEMENTS {
            if index == items.len() {
                items.push(Node::New(format!("{path}[{index}]")));
            }
            if seq.next_element_seed(NodeSeed { node: &mut items[index], row: self.row })?.is_none() {
                if matches!(items[index], Node::New(_)) {
                    items.pop();
                }
                return Ok(());
            }
        }
        while seq.next_element::<IgnoredAny>()?.is_some() {}
        Ok(())
    }
}

/// Finds a key among an object's, without allocating for the keys it knows.
struct KeySeed<'a> {
    fields: &'a [(String, Node)],
    /// The index to try first: the key after the previous one, as the last message had it.
    next: usize,
}

enum Key {
    Found(usize),
    New(String),
}

impl<'de> DeserializeSeed<'de> for KeySeed<'_> {
    type Value = Key;

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<Key, D::Error> {
        deserializer.deserialize_str(self)
    }
}

impl<'de> Visitor<'de> for KeySeed<'_> {
    type Value = Key;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a key")
    }

    fn visit_str<E>(self, v: &str) -> Result<Key, E> {
        if self.fields.get(self.next).is_some_and(|(key, _)| key == v) {
            return Ok(Key::Found(self.next));
        }
        Ok(self.fields.iter().position(|(key, _)| key == v).map_or_else(|| Key::New(v.to_string()), Key::Found))
    }
}

/// The parts of a JSON schema that say where the signals are, properties in their order.
#[derive(Debug, Default)]
struct SchemaNode {
    types: Vec<String>,
    properties: Option<Vec<(String, SchemaNode)>>,
    items: Option<Box<SchemaNode>>,
    prefix_items: Vec<SchemaNode>,
    min_items: Option<u64>,
    max_items: Option<u64>,
    description: String,
    unit: Option<String>,
}

/// `type`: one name or several.
#[derive(Deserialize)]
#[serde(untagged)]
enum Types {
    One(String),
    Several(Vec<String>),
}

/// `items`: one schema for every element, or one per element (the older tuple form).
#[derive(Deserialize)]
#[serde(untagged)]
enum Items {
    Every(Box<SchemaNode>),
    Each(Vec<SchemaNode>),
}

/// `properties`, in the order they are written.
struct Properties(Vec<(String, SchemaNode)>);

impl<'de> Deserialize<'de> for Properties {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Ordered;
        impl<'de> Visitor<'de> for Ordered {
            type Value = Properties;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an object of schemas")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Properties, A::Error> {
                let mut properties = Vec::new();
                while let Some(entry) = map.next_entry::<String, SchemaNode>()? {
                    properties.push(entry);
                }
                Ok(Properties(properties))
            }
        }
        deserializer.deserialize_map(Ordered)
    }
}

impl<'de> Deserialize<'de> for SchemaNode {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Fields;
        impl<'de> Visitor<'de> for Fields {
            type Value = SchemaNode;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a JSON schema")
            }
            // `true` and `false` are schemas too (anything, nothing).
            fn visit_bool<E>(self, _: bool) -> Result<SchemaNode, E> {
                Ok(SchemaNode::default())
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<SchemaNode, A::Error> {
                let mut node = SchemaNode::default();
                let text = |v: serde_json::Value| v.as_str().map(str::to_string);
                while let Some(key) = map.next_key::<String>()? {
                    match key.as_str() {
                        "type" => {
                            node.types = match map.next_value::<Types>()? {
                                Types::One(t) => vec![t],
                                Types::Several(ts) => ts,
                            }
                        }
                        "properties" => node.properties = Some(map.next_value::<Properties>()?.0),
                        "items" => match map.next_value::<Items>()? {
                            Items::Every(items) => node.items = Some(items),
                            Items::Each(each) => node.prefix_items = each,
                        },
                        "prefixItems" => node.prefix_items = map.next_value()?,
                        "minItems" => node.min_items = map.next_value::<serde_json::Value>()?.as_u64(),
                        "maxItems" => node.max_items = map.next_value::<serde_json::Value>()?.as_u64(),
                        "description" => node.description = text(map.next_value()?).unwrap_or_default(),
                        "unit" => node.unit = text(map.next_value()?),
                        _ => {
                            map.next_value::<IgnoredAny>()?;
                        }
                    }
                }
                Ok(node)
            }
        }
        deserializer.deserialize_any(Fields)
    }
}

/// The node of a value this schema describes, at `path`; its signals are added to `signals`.
fn compile(schema: &SchemaNode, path: String, signals: &mut Vec<SignalSpec>) -> Node {
    let is = |t: &str| schema.types.iter().any(|s| s == t);
    if let Some(properties) = &schema.properties {
        let fields = properties.iter().map(|(key, s)| (key.clone(), compile(s, join(&path, key), signals))).collect();
        return Node::Object { path, fields };
    }
    if is("object") {
        return Node::Object { path, fields: Vec::new() };
    }
    if is("number") || is("integer") || is("boolean") {
        let (unit, description) = match &schema.unit {
            Some(unit) => (unit.as_str(), schema.description.trim()),
            None => unit_and_description(&schema.description),
        };
        signals.push(SignalSpec::new(&path, unit, description));
        return Node::Number(signals.len() - 1);
    }
    if is("array") {
        let fixed = match (&schema.items, schema.min_items, schema.max_items) {
            (Some(items), Some(min), Some(max)) if min == max && min as usize <= MAX_ELEMENTS => {
                vec![&**items; min as usize]
            }
            _ => schema.prefix_items.iter().take(MAX_ELEMENTS).collect(),
        };
        let items = fixed.into_iter().enumerate().map(|(i, s)| compile(s, format!("{path}[{i}]"), signals)).collect();
        return Node::Array { path, items };
    }
    if !schema.types.is_empty() {
        // Strings and nulls only.
        return Node::Ignored;
    }
    Node::New(path)
}

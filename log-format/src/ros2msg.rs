//! ROS 2 message definitions (schema encoding `ros2msg`), as rosbag2 and
//! `mcap-ros2-support` write them: the channel's type first, then each type it uses,
//! after a line of `=` and `MSG: <package>/<Type>`.
//!
//! A field is `<type> <name> [<default>]`; a constant (`int32 MAX=10`) is no field. Types
//! are the primitives, `string`/`string<=N`, or another message (`pkg/Type`,
//! `pkg/msg/Type`, or `Type` of the same package); a field may be a fixed array (`[N]`) or
//! a sequence (`[]`, `[<=N]`). `builtin_interfaces/Time` and `Duration` are known without
//! their definitions.

use std::collections::BTreeMap;

/// A primitive type of ROS 2 messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Primitive {
    /// `bool`.
    Bool,
    /// `byte`, `uint8` and `char` (which ROS 2 maps to uint8).
    U8,
    /// `int8`.
    I8,
    /// `int16`.
    I16,
    /// `uint16`.
    U16,
    /// `int32`.
    I32,
    /// `uint32`.
    U32,
    /// `int64`.
    I64,
    /// `uint64`.
    U64,
    /// `float32`.
    F32,
    /// `float64`.
    F64,
}

impl Primitive {
    /// Its size in bytes (and its CDR alignment).
    pub fn size(self) -> usize {
        match self {
            Primitive::Bool | Primitive::U8 | Primitive::I8 => 1,
            Primitive::I16 | Primitive::U16 => 2,
            Primitive::I32 | Primitive::U32 | Primitive::F32 => 4,
            Primitive::I64 | Primitive::U64 | Primitive::F64 => 8,
        }
    }

    fn named(name: &str) -> Option<Self> {
        Some(match name {
            "bool" => Primitive::Bool,
            "byte" | "char" | "uint8" => Primitive::U8,
            "int8" => Primitive::I8,
            "int16" => Primitive::I16,
            "uint16" => Primitive::U16,
            "int32" => Primitive::I32,
            "uint32" => Primitive::U32,
            "int64" => Primitive::I64,
            "uint64" => Primitive::U64,
            "float32" => Primitive::F32,
            "float64" => Primitive::F64,
            _ => return None,
        })
    }
}

/// What a field holds, one element of it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Kind {
    /// A number.
    Primitive(Primitive),
    /// A string (bounded or not).
    String,
    /// Another message, by its full name `pkg/Type`.
    Message(String),
}

/// How many elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Count {
    /// One.
    One,
    /// A fixed array of this length.
    Fixed(usize),
    /// A sequence: the length is in the message.
    Sequence,
}

/// A field of a message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    /// Its name.
    pub name: String,
    /// Its elements' type.
    pub kind: Kind,
    /// How many.
    pub count: Count,
    /// Its comment (`# [unit] description`, as the kalfmu schemas have it).
    pub comment: String,
}

/// A channel's message type and every type it uses, by full name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Definitions {
    /// The channel's type.
    pub root: String,
    /// Each type's fields.
    pub types: BTreeMap<String, Vec<Field>>,
}

/// The time types, whose definitions rosbag2 writes but a hand-made schema may leave out.
const TIME_TYPES: [&str; 2] = ["builtin_interfaces/Time", "builtin_interfaces/Duration"];

/// Whether `name` is a time stamp or a duration: the time of a message, not a signal.
pub fn is_time(name: &str) -> bool {
    TIME_TYPES.contains(&name)
}

/// `pkg/msg/Type` and `pkg/Type` as `pkg/Type`; a bare `Type` in package `package`.
fn full_name(name: &str, package: &str) -> String {
    match name.split('/').collect::<Vec<_>>()[..] {
        [package, "msg", ty] => format!("{package}/{ty}"),
        [_, _] => name.to_string(),
        // ROS 1's convention, which some hand-written ROS 2 schemas keep.
        ["Header"] => "std_msgs/Header".into(),
        _ if package.is_empty() => name.to_string(),
        _ => format!("{package}/{name}"),
    }
}

/// Parses the `ros2msg` schema `text` of a channel whose type is `name`.
pub fn parse(name: &str, text: &str) -> Result<Definitions, String> {
    let root = full_name(name, "");
    let mut types = BTreeMap::new();
    let mut current = root.clone();
    let mut fields = Vec::new();
    let mut separated = false;
    for (number, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        if trimmed.len() >= 3 && trimmed.bytes().all(|b| b == b'=') {
            types.insert(std::mem::take(&mut current), std::mem::take(&mut fields));
            separated = true;
            continue;
        }
        if separated {
            if let Some(ty) = trimmed.strip_prefix("MSG:") {
                current = full_name(ty.trim(), "");
                separated = false;
                continue;
            }
            if trimmed.starts_with("IDL:") {
                return Err(format!("line {}: IDL definitions are not read, only ros2msg", number + 1));
            }
        }
        let package = current.split('/').next().unwrap_or("");
        if let Some(field) = parse_field(trimmed, package).map_err(|what| format!("line {}: {what}", number + 1))? {
            fields.push(field);
        }
    }
    types.insert(current, fields);
    types.remove("");
    for ty in TIME_TYPES {
        types.entry(ty.to_string()).or_insert_with(|| {
            vec![
                Field {
                    name: "sec".into(),
                    kind: Kind::Primitive(Primitive::I32),
                    count: Count::One,
                    comment: "".into(),
                },
                Field {
                    name: "nanosec".into(),
                    kind: Kind::Primitive(Primitive::U32),
                    count: Count::One,
                    comment: "".into(),
                },
            ]
        });
    }
    for fields in types.values() {
        for field in fields {
            if let Kind::Message(ty) = &field.kind {
                if !types.contains_key(ty) {
                    return Err(format!("field '{}' is a {ty}, which the schema does not define", field.name));
                }
            }
        }
    }
    Ok(Definitions { root, types })
}

/// One line of a definition: a field, or `None` for a blank line, a comment or a constant.
fn parse_field(line: &str, package: &str) -> Result<Option<Field>, String> {
    let (declaration, comment) = line.split_once('#').unwrap_or((line, ""));
    let mut words = declaration.split_whitespace();
    let (Some(ty), Some(name)) = (words.next(), words.next()) else {
        return match declaration.trim() {
            "" => Ok(None),
            other => Err(format!("'{other}' is not a field declaration '<type> <name>'")),
        };
    };
    if name.contains('=') || words.next().is_some_and(|w| w.starts_with('=')) {
        return Ok(None);
    }
    let (element, count) = match ty.split_once('[') {
        None => (ty, Count::One),
        Some((element, rest)) => {
            let bound = rest.strip_suffix(']').ok_or_else(|| format!("'{ty}' is not a type"))?;
            let count = if bound.is_empty() || bound.starts_with("<=") {
                Count::Sequence
            } else {
                Count::Fixed(bound.parse().map_err(|_| format!("'{ty}' has no array length"))?)
            };
            (element, count)
        }
    };
    let kind = if let Some(primitive) = Primitive::named(element) {
        Kind::Primitive(primitive)
    } else if element == "string" || element.starts_with("string<=") {
        Kind::String
    } else if element == "wstring" || element.starts_with("wstring<=") {
        return Err(format!("field '{name}' is a wstring, which the reader does not read"));
    } else if element.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '/') && !element.is_empty() {
        Kind::Message(full_name(element, package))
    } else {
        return Err(format!("'{ty}' is not a type"));
    };
    Ok(Some(Field { name: name.to_string(), kind, count, comment: comment.trim().to_string() }))
}

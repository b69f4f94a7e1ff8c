//! `NAME=VALUE`: one FMU parameter value as a command takes it (`--set m1=4.2`) and as
//! `kalfmu-tune` prints its estimates, so that they can be pasted into the next command.

use std::fmt;
use std::str::FromStr;

/// A parameter's name and value.
#[derive(Debug, Clone, PartialEq)]
pub struct Assignment {
    /// The FMU variable's name.
    pub name: String,
    /// Its value.
    pub value: f64,
}

impl FromStr for Assignment {
    type Err = String;

    /// `NAME=VALUE`: a name of letters, digits, `_` and `.` (starting with a letter or
    /// `_`), and a number (`inf`, `nan` refused: no FMU parameter takes them).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (name, value) = s.split_once('=').ok_or_else(|| format!("'{s}' is not NAME=VALUE"))?;
        let name = name.trim();
        let valid = name.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.');
        if !valid {
            return Err(format!("'{name}' is not a parameter name (a letter, then letters, digits, _ or .)"));
        }
        let number: f64 = value.trim().parse().map_err(|_| format!("{name}: '{}' is not a number", value.trim()))?;
        if !number.is_finite() {
            return Err(format!("{name}: the value must be finite, got {number}"));
        }
        Ok(Assignment { name: name.into(), value: number })
    }
}

impl fmt::Display for Assignment {
    /// `NAME=VALUE` with the shortest value that reads back to the same number.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}={:e}", self.name, self.value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assignments_parse_print_and_read_back() {
        let a: Assignment = " load_noise_intensity = 1.56e6 ".parse().unwrap();
        assert_eq!(a, Assignment { name: "load_noise_intensity".into(), value: 1.56e6 });
        assert_eq!(a.to_string(), "load_noise_intensity=1.56e6");
        let b = Assignment { name: "r".into(), value: 0.1 + 0.2 };
        assert_eq!(b.to_string().parse::<Assignment>().unwrap(), b, "the printed value reads back bit for bit");
        for bad in ["m1", "=3", "1m=3", "m1=x", "m1=inf", "m 1=2"] {
            assert!(bad.parse::<Assignment>().is_err(), "{bad}");
        }
    }
}

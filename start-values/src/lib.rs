//! FMU start values as a user gives them to our commands: `NAME=VALUE` assignments
//! ([`Assignment`], `--set m1=4.2`) and SSP parameter-value files ([`ssv`], `--values
//! tuned.ssv`), the two forms `kalfmu-tune` writes its estimates in. [`Options`] is the
//! pair of command-line options every command that runs an estimator takes, and
//! [`StartValues`] what they amount to: one value per name, in the order given, the
//! files first and then `--set`, a later value replacing an earlier one.

pub mod assignment;
pub mod ssv;

use std::path::PathBuf;

pub use assignment::Assignment;

/// The command-line options: SSV files, then single values.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct Options {
    /// An FMU parameter's start value, over the study's own (repeatable; `kalfmu-tune`
    /// prints its estimates as such lines).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<Assignment>,
    /// FMU parameter start values from an SSP parameter-value file (repeatable; applied
    /// before --set; `kalfmu-tune --ssv` writes one).
    #[arg(long = "values", value_name = "FILE.ssv")]
    pub values: Vec<PathBuf>,
}

/// Start values by name, in the order first given.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StartValues {
    values: Vec<(String, f64)>,
}

impl StartValues {
    /// No start values: every parameter at the study's value.
    pub fn none() -> Self {
        Self::default()
    }

    /// The values of `options`: each SSV file in turn, then each `--set`.
    pub fn from_options(options: &Options) -> Result<Self, String> {
        let mut values = Self::none();
        for file in &options.values {
            let set = ssv::read(file).map_err(|e| format!("{}: {e}", file.display()))?;
            for (name, value) in set.values() {
                values.insert(&name, value);
            }
        }
        for a in &options.set {
            values.insert(&a.name, a.value);
        }
        Ok(values)
    }

    /// Sets `name` to `value`, replacing an earlier value of it in its place.
    pub fn insert(&mut self, name: &str, value: f64) {
        match self.values.iter_mut().find(|(n, _)| n == name) {
            Some(slot) => slot.1 = value,
            None => self.values.push((name.to_string(), value)),
        }
    }

    /// The value given for `name`, if any.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.values.iter().find(|(n, _)| n == name).map(|(_, v)| *v)
    }

    /// Whether none is given.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// The names and values, in order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, f64)> {
        self.values.iter().map(|(n, v)| (n.as_str(), *v))
    }

    /// `defaults` with the given values over them: a default named here takes the value
    /// given, in its place; the names the defaults lack follow, in order.
    pub fn over(&self, defaults: &[(&str, f64)]) -> Vec<(String, f64)> {
        let mut merged: Vec<(String, f64)> =
            defaults.iter().map(|(n, v)| (n.to_string(), self.get(n).unwrap_or(*v))).collect();
        for (name, value) in self.iter() {
            if !defaults.iter().any(|(n, _)| *n == name) {
                merged.push((name.to_string(), value));
            }
        }
        merged
    }

    /// The header line of a study that sets these values on its FMU runs and on its
    /// in-process filter, naming `fmu_only`, those the in-process filter has no parameter
    /// for; `None` without any value.
    pub fn header(&self, fmu_only: &[String]) -> Option<String> {
        if self.is_empty() {
            return None;
        }
        let mut line =
            format!("start values, over the study's in every FMU run and in the in-process filter: {}", self.summary());
        if !fmu_only.is_empty() {
            line +=
                &format!("; in the FMU only (the in-process filter has no such parameter): {}", fmu_only.join(", "));
        }
        Some(line)
    }

    /// One line for a report: `NAME=VALUE NAME=VALUE …`, or `none`.
    pub fn summary(&self) -> String {
        if self.is_empty() {
            return "none".into();
        }
        self.values
            .iter()
            .map(|(name, value)| Assignment { name: name.clone(), value: *value }.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// A filter set-up whose parameters are set by the FMU's names: what an in-process run
/// takes of the start values a user gives, so that a value reaches the in-process filter as
/// it reaches the FMU.
pub trait SetByName {
    /// Whether [`SetByName::set`] takes `name`.
    fn takes(name: &str) -> bool
    where
        Self: Sized;

    /// Sets the parameter `name` to `value`. An error names what is wrong (a name it does
    /// not take, or a value the FMU would refuse too) and changes nothing.
    fn set(&mut self, name: &str, value: f64) -> Result<(), String>;

    /// Every start value of `values` it takes; returns the names it does not take, which
    /// only an FMU run can be given. A value of a name it takes that [`SetByName::set`]
    /// refuses is an error.
    fn set_known(&mut self, values: &StartValues) -> Result<Vec<String>, String>
    where
        Self: Sized,
    {
        let mut fmu_only = Vec::new();
        for (name, value) in values.iter() {
            if Self::takes(name) {
                self.set(name, value).map_err(|e| format!("start value {e}"))?;
            } else {
                fmu_only.push(name.to_string());
            }
        }
        Ok(fmu_only)
    }

    /// Every start value of `values`, an in-process run's: a name it does not take is an
    /// error.
    fn set_all(&mut self, values: &StartValues) -> Result<(), String> {
        for (name, value) in values.iter() {
            self.set(name, value).map_err(|e| format!("start value {e}"))?;
        }
        Ok(())
    }
}

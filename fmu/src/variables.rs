//! The description of an FMU's variables: one table per estimator, the single
//! source of truth for the C ABI (value references), the instance's storage,
//! the generated `modelDescription.xml` and the documentation.
//!
//! Value references are the variables' positions in the table; every value is
//! stored as an `f64` (Integers, Booleans and Enumerations are exact in it).

use std::borrow::Cow;

/// `causality` of a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    /// Set by the importer before initialisation (or while running, if tunable).
    Parameter,
    /// Set by the importer before every step.
    Input,
    /// Computed by the FMU.
    Output,
}

/// `variability` of a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variability {
    /// Parameters fixed after initialisation.
    Fixed,
    /// Parameters that may change between steps.
    Tunable,
    /// Integer and Boolean outputs.
    Discrete,
    /// Real inputs and outputs.
    Continuous,
}

/// The value type of a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `fmi2Real`.
    Real,
    /// `fmi2Integer`.
    Integer,
    /// `fmi2Boolean`.
    Boolean,
    /// An enumeration (set and got as `fmi2Integer`), of the named type.
    Enumeration(&'static EnumerationType),
}

/// An enumeration type declared in `<TypeDefinitions>`.
#[derive(Debug, PartialEq, Eq)]
pub struct EnumerationType {
    /// The type name.
    pub name: &'static str,
    /// `(value, item name, description)`.
    pub items: &'static [(i32, &'static str, &'static str)],
}

/// What the generic FMU layer does with a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// A parameter read by the estimator by name.
    Parameter,
    /// Input: row `j` of the measurement vector.
    Measurement(usize),
    /// Input: component `j` of the known input `u` of the model (a control, e.g. a
    /// deflection), held from the communication point it is set at (`timing.rs`).
    Control(usize),
    /// Output: state estimate `i`.
    Estimate(usize),
    /// Output: standard deviation of state estimate `i`.
    EstimateStd(usize),
    /// Output: normalised innovation squared of the last update.
    Nis,
    /// Output: the adapted scale on the process noise `Q`.
    ProcessNoiseScale,
    /// Output: measurement rows skipped so far (non-finite inputs).
    SkippedMeasurements,
    /// Output: measurement rows rejected by the gate so far.
    RejectedMeasurements,
    /// Output: measurement row `j`'s channel is faulty.
    ChannelFault(usize),
    /// Output: what became of measurement row `j` in the update the outputs
    /// show (an [`crate::estimators::INPUT_STATUS`] value).
    InputStatus(usize),
    /// Output: the filter is consistent, not lost, and has not failed.
    FilterHealthy,
    /// Output: whether the master's call pattern fits `input_timing` (an
    /// [`crate::estimators::INPUT_TIMING_CHECK`] value, `input_timing_check.rs`).
    InputTimingCheck,
    /// Output `k` of the estimator's derived outputs (`Descriptor::derive`).
    Derived(usize),
    /// Output: the fixed-lag smoothed estimate of the `a`-th of the estimator's
    /// smoothed states (`Descriptor::smoothed_states`).
    Smoothed(usize),
    /// Output: its standard deviation.
    SmoothedStd(usize),
    /// Output: the time the smoothed estimates describe.
    SmoothedTime,
    /// Input of a plant: its input `j` (`crate::plants::Plant::set_input`), held
    /// from the communication point it is set at over the step.
    PlantInput(usize),
    /// Output of a plant: its output `k` (`crate::plants::Plant::outputs`).
    PlantOutput(usize),
}

/// One scalar variable.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// Unique name: written in the tables, or made from another variable's
    /// (`<input>_status`) when the table is built.
    pub name: Cow<'static, str>,
    /// Description shown by importers.
    pub description: &'static str,
    /// Value type.
    pub kind: Kind,
    /// Causality.
    pub causality: Causality,
    /// Variability.
    pub variability: Variability,
    /// The start value (inputs and parameters); outputs have none.
    pub start: Option<f64>,
    /// Unit, declared in `<UnitDefinitions>`.
    pub unit: Option<&'static str>,
    /// Lower bound.
    pub min: Option<f64>,
    /// Upper bound.
    pub max: Option<f64>,
    /// What the FMU layer does with it.
    pub role: Role,
    /// A measurement that is missing most of the time (a position marker passed now
    /// and then): its absence is normal, not reported.
    pub intermittent: bool,
}

impl Variable {
    /// A fixed Real parameter.
    pub fn parameter(name: &'static str, unit: &'static str, start: f64, description: &'static str) -> Self {
        Self {
            name: Cow::Borrowed(name),
            description,
            kind: Kind::Real,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            start: Some(start),
            unit: Some(unit),
            min: None,
            max: None,
            role: Role::Parameter,
            intermittent: false,
        }
    }

    /// A tunable Real parameter.
    pub fn tunable(name: &'static str, unit: &'static str, start: f64, description: &'static str) -> Self {
        Self { variability: Variability::Tunable, ..Self::parameter(name, unit, start, description) }
    }

    /// A Real input: measurement row `row`.
    pub fn measurement(name: &'static str, unit: &'static str, row: usize, description: &'static str) -> Self {
        Self {
            causality: Causality::Input,
            variability: Variability::Continuous,
            start: Some(0.0),
            role: Role::Measurement(row),
            ..Self::parameter(name, unit, 0.0, description)
        }
    }

    /// A Real input: component `index` of the known input `u` (a control). Its start
    /// value, 0, is a value: unlike a measurement, a control is never missing.
    pub fn control(name: &'static str, unit: &'static str, index: usize, description: &'static str) -> Self {
        Self { role: Role::Control(index), ..Self::measurement(name, unit, 0, description) }
    }

    /// A Real output.
    pub fn output(name: &'static str, unit: &'static str, role: Role, description: &'static str) -> Self {
        Self {
            causality: Causality::Output,
            variability: Variability::Continuous,
            start: None,
            role,
            ..Self::parameter(name, unit, 0.0, description)
        }
    }

    /// A fixed Integer parameter in `[min, max]`.
    pub fn integer_parameter(
        name: &'static str,
        start: u32,
        (min, max): (u32, u32),
        description: &'static str,
    ) -> Self {
        Self { kind: Kind::Integer, unit: None, ..Self::parameter(name, "1", f64::from(start), description) }
            .bounded(Some(f64::from(min)), Some(f64::from(max)))
    }

    /// An Integer output that counts (discrete).
    pub fn count(name: &'static str, role: Role, description: &'static str) -> Self {
        Self {
            kind: Kind::Integer,
            variability: Variability::Discrete,
            unit: None,
            ..Self::output(name, "1", role, description)
        }
    }

    /// A Boolean output (discrete).
    pub fn flag(name: &'static str, role: Role, description: &'static str) -> Self {
        Self {
            kind: Kind::Boolean,
            variability: Variability::Discrete,
            unit: None,
            ..Self::output(name, "1", role, description)
        }
    }

    /// An Enumeration output of type `t` (discrete), called `name`.
    pub fn enumeration_output(
        name: String,
        t: &'static EnumerationType,
        role: Role,
        description: &'static str,
    ) -> Self {
        Self {
            name: Cow::Owned(name),
            kind: Kind::Enumeration(t),
            variability: Variability::Discrete,
            unit: None,
            ..Self::output("", "1", role, description)
        }
    }

    /// An intermittent measurement (see [`Variable::intermittent`]).
    pub fn intermittent(self) -> Self {
        Self { intermittent: true, ..self }
    }

    /// With bounds.
    pub fn bounded(self, min: Option<f64>, max: Option<f64>) -> Self {
        Self { min, max, ..self }
    }

    /// Whether the importer may set it in `state`-dependent ways at all.
    pub fn is_settable(&self) -> bool {
        self.causality != Causality::Output
    }
}

/// Checks what every table must be: unique names, and causality, variability and
/// start value in a combination FMI allows.
pub fn check_table(variables: &[Variable]) -> Result<(), String> {
    for (i, v) in variables.iter().enumerate() {
        if variables[..i].iter().any(|w| w.name == v.name) {
            return Err(format!("duplicate variable name {}", v.name));
        }
        let ok = matches!(
            (v.causality, v.variability, v.start.is_some()),
            (Causality::Parameter, Variability::Fixed | Variability::Tunable, true)
                | (Causality::Input, Variability::Continuous | Variability::Discrete, true)
                | (Causality::Output, Variability::Continuous | Variability::Discrete, false)
        );
        if !ok {
            return Err(format!("variable {} has an illegal causality/variability/start combination", v.name));
        }
    }
    Ok(())
}

/// A unit and its exponents of the base units `kg, m, s, rad`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Unit {
    /// The unit name.
    pub name: &'static str,
    /// Exponents of kg, m, s, rad.
    pub exponents: [i8; 4],
}

/// Every unit the FMUs use; `<UnitDefinitions>` declares those a description uses.
pub const UNITS: &[Unit] = &[
    Unit { name: "1", exponents: [0, 0, 0, 0] },
    Unit { name: "s", exponents: [0, 0, 1, 0] },
    Unit { name: "1/s", exponents: [0, 0, -1, 0] },
    Unit { name: "kg", exponents: [1, 0, 0, 0] },
    Unit { name: "m", exponents: [0, 1, 0, 0] },
    Unit { name: "m/s", exponents: [0, 1, -1, 0] },
    Unit { name: "m/s2", exponents: [0, 1, -2, 0] },
    Unit { name: "N", exponents: [1, 1, -2, 0] },
    Unit { name: "N/s", exponents: [1, 1, -3, 0] },
    Unit { name: "N/m", exponents: [1, 0, -2, 0] },
    Unit { name: "N.s/m", exponents: [1, 0, -1, 0] },
    Unit { name: "N2/s3", exponents: [2, 2, -7, 0] },
    Unit { name: "N2/s", exponents: [2, 2, -5, 0] },
    Unit { name: "kg.m2", exponents: [1, 2, 0, 0] },
    Unit { name: "m2", exponents: [0, 2, 0, 0] },
    Unit { name: "m2/s", exponents: [0, 2, -1, 0] },
    Unit { name: "m2/s5", exponents: [0, 2, -5, 0] },
    Unit { name: "rad", exponents: [0, 0, 0, 1] },
    Unit { name: "rad/s", exponents: [0, 0, -1, 1] },
];

/// Read access to the parameter values of an instance, by name.
pub struct Parameters<'a> {
    variables: &'a [Variable],
    values: &'a [f64],
}

impl<'a> Parameters<'a> {
    /// Values aligned with `variables`.
    pub fn new(variables: &'a [Variable], values: &'a [f64]) -> Self {
        Self { variables, values }
    }

    /// The value of the variable called `name`.
    pub fn get(&self, name: &str) -> Result<f64, String> {
        self.variables
            .iter()
            .position(|v| v.name == name)
            .map(|i| self.values[i])
            .ok_or_else(|| format!("the FMU has no variable '{name}'"))
    }

    /// A value that must be finite and positive.
    pub fn positive(&self, name: &str) -> Result<f64, String> {
        let v = self.get(name)?;
        if v > 0.0 && v.is_finite() {
            Ok(v)
        } else {
            Err(format!("parameter {name} must be positive and finite, got {v}"))
        }
    }

    /// A value that must be finite and non-negative.
    pub fn non_negative(&self, name: &str) -> Result<f64, String> {
        let v = self.get(name)?;
        if v >= 0.0 && v.is_finite() {
            Ok(v)
        } else {
            Err(format!("parameter {name} must be non-negative and finite, got {v}"))
        }
    }

    /// A value that must be finite.
    pub fn finite(&self, name: &str) -> Result<f64, String> {
        let v = self.get(name)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(format!("parameter {name} must be finite, got {v}"))
        }
    }
}

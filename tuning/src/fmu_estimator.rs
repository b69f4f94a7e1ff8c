//! An estimator FMU's filter as a [`FilterFactory`]: the FMU's own table
//! (`kalfmu_fmu::estimators`), its parameter values (the start values, then what the log
//! says was set, then the user's), and the parameters to fit. A filter is built by the
//! FMU's own code, as an instance builds it at `fmi2ExitInitializationMode`
//! (`kalfmu_fmu::estimating::build_filter`). The supervisor (gate, fault flags) is left out
//! of the fit: the likelihood caps gross errors itself (`likelihood.rs`); the smoothed log
//! runs the whole loop ([`FmuEstimator::supervised`]).

use estimator::{FilterKind, StateEstimator, SupervisedFilter};
use kalfmu_fmu::estimating;
use kalfmu_fmu::estimators::{self, Descriptor, FILTER_KIND};
use kalfmu_fmu::variables::{Causality, Kind, Variability};

use crate::likelihood::FilterFactory;

/// An estimator FMU set up for a fit.
pub struct FmuEstimator {
    descriptor: Descriptor,
    /// Every variable's value, by value reference (outputs NaN).
    values: Vec<f64>,
    /// The fitted parameters, by value reference.
    fitted: Vec<usize>,
}

impl FmuEstimator {
    /// The estimator of `descriptor` at its start values, fitting its noise parameters.
    pub fn new(descriptor: Descriptor) -> Self {
        let values = descriptor.variables.iter().map(|v| v.start.unwrap_or(f64::NAN)).collect();
        let mut estimator = Self { descriptor, values, fitted: Vec::new() };
        estimator.fitted = estimator.noise_parameters().iter().filter_map(|n| estimator.index(n)).collect();
        estimator
    }

    /// The estimator whose FMU is `model_identifier`.
    pub fn by_identifier(model_identifier: &str) -> Result<Self, String> {
        let all = estimators::all();
        let known: Vec<&str> = all.iter().map(|d| d.model_identifier).collect();
        let known = known.join(", ");
        estimators::all()
            .into_iter()
            .find(|d| d.model_identifier == model_identifier)
            .map(Self::new)
            .ok_or_else(|| format!("no estimator FMU {model_identifier}; there are {known}"))
    }

    /// The FMU's table.
    pub fn descriptor(&self) -> &Descriptor {
        &self.descriptor
    }

    fn index(&self, name: &str) -> Option<usize> {
        self.descriptor.variables.iter().position(|v| v.name == name)
    }

    /// The value of the parameter `name`.
    pub fn value(&self, name: &str) -> Result<f64, String> {
        self.index(name)
            .map(|i| self.values[i])
            .ok_or_else(|| format!("{} has no variable {name}", self.descriptor.model_identifier))
    }

    /// The unit of the variable `name`.
    pub fn unit(&self, name: &str) -> Option<&'static str> {
        self.index(name).and_then(|i| self.descriptor.variables[i].unit)
    }

    /// Sets the parameter `name` (its start value for the fit, or its fixed value),
    /// refusing what the FMU would refuse: no such parameter, an input or output, a value
    /// outside its bounds, an enumeration value that is none of its items.
    pub fn set(&mut self, name: &str, value: f64) -> Result<(), String> {
        let id = self.descriptor.model_identifier;
        let i = self.index(name).ok_or_else(|| format!("{id} has no parameter {name}"))?;
        let var = &self.descriptor.variables[i];
        if var.causality != Causality::Parameter {
            return Err(format!("{name} is not a parameter of {id} (it is an input or an output)"));
        }
        if let Kind::Enumeration(t) = var.kind {
            if !t.items.iter().any(|(v, _, _)| f64::from(*v) == value) {
                return Err(format!("{value} is not a value of {} (parameter {name})", t.name));
            }
        }
        let below = var.min.is_some_and(|m| value < m) || value.is_nan();
        let above = var.max.is_some_and(|m| value > m);
        if below || above {
            return Err(format!(
                "{value} is outside [{}, {}] for parameter {name}",
                var.min.map_or("-inf".into(), |m| m.to_string()),
                var.max.map_or("inf".into(), |m| m.to_string())
            ));
        }
        self.values[i] = value;
        Ok(())
    }

    /// Sets the filter method (the `filter` parameter).
    pub fn set_filter(&mut self, kind: FilterKind) -> Result<(), String> {
        let value = FILTER_KIND
            .items
            .iter()
            .map(|(v, _, _)| f64::from(*v))
            .find(|&v| estimators::filter_kind(v) == Ok(kind))
            .ok_or_else(|| format!("the FMU has no filter {kind}"))?;
        self.set("filter", value)
    }

    /// The filter method the parameters select.
    pub fn filter(&self) -> Result<FilterKind, String> {
        estimators::filter_kind(self.value("filter")?)
    }

    /// The noise parameters: the tunable Real parameters (the process noise intensities
    /// and standard deviations, the sensors' standard deviations), in table order.
    pub fn noise_parameters(&self) -> Vec<String> {
        self.descriptor
            .variables
            .iter()
            .filter(|v| v.causality == Causality::Parameter && v.variability == Variability::Tunable)
            .filter(|v| v.kind == Kind::Real)
            .map(|v| v.name.to_string())
            .collect()
    }

    /// Fits the parameters `names` (Real parameters with a positive value).
    pub fn choose_fitted(&mut self, names: &[String]) -> Result<(), String> {
        let mut fitted = Vec::new();
        for name in names {
            let id = self.descriptor.model_identifier;
            let i = self.index(name).ok_or_else(|| format!("{id} has no parameter {name}"))?;
            let var = &self.descriptor.variables[i];
            if var.causality != Causality::Parameter || var.kind != Kind::Real {
                return Err(format!("{name} is not a Real parameter of {id}: it cannot be fitted"));
            }
            if fitted.contains(&i) {
                return Err(format!("{name} is named twice"));
            }
            fitted.push(i);
        }
        if fitted.is_empty() {
            return Err("no parameter to fit".into());
        }
        self.fitted = fitted;
        Ok(())
    }

    /// The names of the fitted parameters, in the fit's order.
    pub fn fitted_names(&self) -> Vec<String> {
        self.fitted.iter().map(|&i| self.descriptor.variables[i].name.to_string()).collect()
    }

    /// The fitted parameters' current values: the start of the fit. Each must be positive
    /// (the fit works on logarithms).
    pub fn start_values(&self) -> Result<Vec<f64>, String> {
        self.fitted
            .iter()
            .map(|&i| {
                let v = self.values[i];
                if v > 0.0 && v.is_finite() {
                    Ok(v)
                } else {
                    Err(format!(
                        "the start value of {} is {v}; a fitted parameter needs a positive start (--set {}=...)",
                        self.descriptor.variables[i].name, self.descriptor.variables[i].name
                    ))
                }
            })
            .collect()
    }

    /// Every variable's value with the fitted parameters at `fitted`.
    fn values_with(&self, fitted: &[f64]) -> Vec<f64> {
        let mut values = self.values.clone();
        for (&i, &v) in self.fitted.iter().zip(fitted) {
            values[i] = v;
        }
        values
    }

    /// The FMU's whole estimation loop with the fitted parameters at `fitted`: its filter
    /// behind its supervisor (gate, fault flags, jumps, adaptation), as an instance runs
    /// it, the belief at `start_time`.
    pub fn supervised(&self, fitted: &[f64], start_time: f64) -> Result<SupervisedFilter, String> {
        let values = self.values_with(fitted);
        let filter = estimating::build_filter(&self.descriptor, &values, start_time)?;
        let supervisor = estimating::build_supervisor(&self.descriptor, &values, filter.as_ref())?;
        SupervisedFilter::new(filter, supervisor).map_err(|e| e.to_string())
    }

    /// Every parameter's name and value with the fitted ones at `fitted`.
    pub fn parameters_with(&self, fitted: &[f64]) -> Vec<(String, f64)> {
        let values = self.values_with(fitted);
        self.descriptor
            .variables
            .iter()
            .zip(values)
            .filter(|(v, _)| v.causality == Causality::Parameter)
            .map(|(v, value)| (v.name.to_string(), value))
            .collect()
    }

    /// Checks what the fit relies on: the input timing is the FMU's default (an input set
    /// at `t` is the measurement of `t`, as the log's time stamps say), and a filter can
    /// be built at the start values.
    pub fn check(&self) -> Result<(), String> {
        if self.value("input_timing")? != 1.0 {
            return Err("input_timing = 2 (step_end): the log's time stamps would not be the measurements' \
                        times; fit logs made with the default input timing"
                .into());
        }
        self.build(&self.start_values()?, 0.0).map(|_| ())
    }
}

impl FilterFactory for FmuEstimator {
    fn parameter_count(&self) -> usize {
        self.fitted.len()
    }

    fn build(&self, fitted: &[f64], start_time: f64) -> Result<Box<dyn StateEstimator>, String> {
        estimating::build_filter(&self.descriptor, &self.values_with(fitted), start_time)
    }

    fn sample_time(&self) -> f64 {
        self.value("sample_time").unwrap_or(f64::NAN)
    }
}

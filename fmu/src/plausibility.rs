//! What an estimator FMU may plausibly output, and which noise settings it
//! refuses, both derived from the user's own parameters.
//!
//! * **A lost filter is never reported OK.** Each estimator says how large
//!   its unknown inputs (a load, a wheel–rail force, an aerodynamic
//!   coefficient) can plausibly be from its own parameters
//!   ([`Descriptor::plausible_bound`]): S2 and S3 100 times the static wheel
//!   load; the others, whose parameters hold no such scale, [`PRIOR_SIGMAS`]
//!   prior σ from the prior mean (the prior the user sets says where the
//!   input can be). An estimate beyond it, a σ above it, or a value that is
//!   not finite, is no estimate: the filter has lost the state (a noise
//!   setting decades off, a covariance that blew up). A step that ends there
//!   returns fmi2Warning, the outputs keep the last plausible estimate, and
//!   `filter_healthy` is false until the estimate is plausible again.
//! * **A noise σ many decades below its signal is refused.** Each
//!   measurement's spread under the prior, `√(H·P₀·Hᵀ)ᵢᵢ`, is the scale of
//!   the signal the user expects; a sensor noise `r_<input>_std` more than
//!   `1/`[`NOISE_FLOOR`] below it is no sensor's (2e-13 m/s² typed for
//!   2e-3), and it makes the filter trust a typo so far that it diverges.
//!   `fmi2ExitInitializationMode` refuses it and names the parameter.

use estimator::{PlausibleBound, PlausibleRange, StateEstimator};

use crate::estimators::Descriptor;
use crate::variables::{Parameters, Role, Variable};

/// How many prior σ from the prior mean an unknown input may plausibly be.
pub const PRIOR_SIGMAS: f64 = 1e3;

/// How far below its prior spread a measurement's noise σ may be: nine
/// decades. A prior is often wide (S3's 0.1 m on every position spreads a
/// bogie accelerometer over 350 m/s², where a quiet twist measures 1e-4 m/s²
/// of noise: six decades below), so the floor catches typos of many decades
/// (2e-13 for 2e-3: fifteen), not honest quiet sensors.
pub const NOISE_FLOOR: f64 = 1e-9;

/// The plausible range of `descriptor`'s unknown inputs with the parameter
/// values `values`, for a filter whose belief at the start is `prior`: the
/// estimator's own bound around 0, or [`PRIOR_SIGMAS`] prior σ around the
/// prior mean (a state with a σ of 0 in the prior gets no bound then). The
/// supervisor restarts a belief outside it and judges it
/// (`estimator::PlausibleRange`); the instance reports it.
pub fn plausible_range(
    descriptor: &Descriptor,
    values: &[f64],
    prior: &dyn StateEstimator,
) -> Result<PlausibleRange, String> {
    let own = (descriptor.plausible_bound)(&Parameters::new(&descriptor.variables, values))?;
    let bounds = descriptor
        .unknown_inputs
        .iter()
        .filter_map(|&state| match own {
            Some(bound) => Some(PlausibleBound { state, centre: 0.0, bound }),
            None => {
                let std = prior.variance(state).max(0.0).sqrt();
                (std > 0.0 && std.is_finite()).then(|| PlausibleBound {
                    state,
                    centre: prior.mean()[state],
                    bound: PRIOR_SIGMAS * std,
                })
            }
        })
        .collect();
    PlausibleRange::new(prior.state_dim(), bounds).map_err(|e| e.to_string())
}

/// Refuses a sensor noise σ more than `1/`[`NOISE_FLOOR`] below the
/// spread the prior of `filter` gives its measurement (see the module
/// documentation); `filter` is a fresh one, which this updates once.
pub fn check_noise(descriptor: &Descriptor, filter: &mut dyn StateEstimator) -> Result<(), String> {
    let m = descriptor.measurement_dim();
    let r: Vec<f64> = (0..m).map(|i| filter.noise().r()[(i, i)]).collect();
    let zeros = vec![0.0; m];
    let innovation = filter.update(&zeros).map_err(|e| e.to_string())?;
    for (row, &variance) in r.iter().enumerate() {
        let spread = (innovation.covariance()[(row, row)] - variance).max(0.0).sqrt();
        let std = variance.max(0.0).sqrt();
        if !(spread > 0.0 && spread.is_finite()) || std >= NOISE_FLOOR * spread {
            continue;
        }
        let input = descriptor.variables.iter().find(|v| v.role == Role::Measurement(row));
        let name = input.map_or_else(|| format!("row {row}"), |v| v.name.to_string());
        let unit = input.and_then(|v| v.unit).unwrap_or("");
        let parameter = noise_parameter(&descriptor.variables, &name);
        return Err(format!(
            "{parameter} = {std:e} {unit} is more than nine decades below the spread of {name} under the \
             prior ({spread:.3e} {unit}): no sensor is that precise, and a filter told so diverges (a typo?)"
        ));
    }
    Ok(())
}

/// The name of the parameter that sets the noise of input `name`.
fn noise_parameter(variables: &[Variable], name: &str) -> String {
    let wanted = format!("r_{name}_std");
    variables.iter().find(|v| v.name == wanted).map_or_else(|| format!("the noise σ of {name}"), |v| v.name.to_string())
}

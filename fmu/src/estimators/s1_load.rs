//! The S1 load-identification estimator: the unknown load on the free mass of
//! a two-mass chain with a nonlinear ground link, from the accelerations of
//! both masses (study S1, Gong et al. 2024). The estimation model is the
//! library's `Oscillator2DofLoad`: state `[z₁, z₂, F, ż₁, ż₂, Ḟ]`.
//!
//! Parameters: the chain (fixed), the filter set-up (fixed), the noise (tunable).
//! The load's process noise is one physical intensity: `F̈` white with
//! `load_noise_intensity` (N²/s³), discretised exactly over the sample time.

use estimator::models::{Oscillator2Dof, Oscillator2DofLoad, PiecewiseLinear};
use estimator::{
    build_filter, Discretized, FilterKind, Gaussian, Noise, StateEstimator, SupervisorSettings, UnscentedParams,
};
use nalgebra::{DMatrix, DVector};

use super::{bound_from_prior, no_derived_outputs, no_quantized_steps, DefaultExperiment, Descriptor};
use crate::variables::{Parameters, Role, Variable};

const STATE: [(&str, &str, &str); 6] = [
    ("z1", "m", "displacement of mass 1"),
    ("z2", "m", "displacement of mass 2"),
    ("F", "N", "load on mass 2"),
    ("z1_dot", "m/s", "velocity of mass 1"),
    ("z2_dot", "m/s", "velocity of mass 2"),
    ("F_dot", "N/s", "rate of the load"),
];

pub(super) fn descriptor() -> Descriptor {
    let mut v = vec![
        Variable::measurement("z1_ddot", "m/s2", 0, "measured acceleration of mass 1 (NaN: missing)"),
        Variable::measurement("z2_ddot", "m/s2", 1, "measured acceleration of mass 2 (NaN: missing)"),
        Variable::flag(
            "z1_ddot_fault",
            Role::ChannelFault(0),
            "z1_ddot is faulty: rejected by the gate, stuck or missing for fault_after samples in a row",
        ),
        Variable::flag(
            "z2_ddot_fault",
            Role::ChannelFault(1),
            "z2_ddot is faulty: rejected by the gate, stuck or missing for fault_after samples in a row",
        ),
        Variable::output("F", "N", Role::Estimate(2), "estimated load on mass 2"),
        Variable::output("F_std", "N", Role::EstimateStd(2), "standard deviation of the estimated load"),
    ];
    let names = [
        ("z1", "z1_std"),
        ("z2", "z2_std"),
        ("", ""),
        ("z1_dot", "z1_dot_std"),
        ("z2_dot", "z2_dot_std"),
        ("F_dot", "F_dot_std"),
    ];
    let descriptions = [
        ("estimated displacement of mass 1", "standard deviation of z1"),
        ("estimated displacement of mass 2", "standard deviation of z2"),
        ("", ""),
        ("estimated velocity of mass 1", "standard deviation of z1_dot"),
        ("estimated velocity of mass 2", "standard deviation of z2_dot"),
        ("estimated rate of the load", "standard deviation of F_dot"),
    ];
    for i in [0, 1, 3, 4, 5] {
        let unit = STATE[i].1;
        v.push(Variable::output(names[i].0, unit, Role::Estimate(i), descriptions[i].0));
        v.push(Variable::output(names[i].1, unit, Role::EstimateStd(i), descriptions[i].1));
    }
    v.extend(chain_variables());
    v.push(Variable::integer_parameter("rk4_substeps", 1, (1, 1000), "RK4 steps per filter sample"));
    let x0 = ["x0_z1", "x0_z2", "x0_F", "x0_z1_dot", "x0_z2_dot", "x0_F_dot"];
    let p0 = ["p0_z1_std", "p0_z2_std", "p0_F_std", "p0_z1_dot_std", "p0_z2_dot_std", "p0_F_dot_std"];
    let p0_start = [1e-3, 1e-3, 20.0, 1e-3, 1e-3, 500.0];
    for i in 0..6 {
        v.push(Variable::parameter(x0[i], STATE[i].1, 0.0, "initial estimate"));
        v.push(
            Variable::parameter(p0[i], STATE[i].1, p0_start[i], "initial standard deviation").bounded(Some(0.0), None),
        );
    }
    v.extend([
        Variable::tunable("q_z_std", "m", 1e-6, "process noise std of z1, z2 per sample").bounded(Some(0.0), None),
        Variable::tunable("q_z_dot_std", "m/s", 1e-5, "process noise std of z1_dot, z2_dot per sample")
            .bounded(Some(0.0), None),
        Variable::tunable(
            "load_noise_intensity",
            "N2/s3",
            1.56e6,
            "intensity q of the white load acceleration (F as a second-order random walk)",
        )
        .bounded(Some(0.0), None),
        Variable::tunable("r_z1_ddot_std", "m/s2", 0.01, "noise std of the z1_ddot sensor").bounded(Some(0.0), None),
        Variable::tunable("r_z2_ddot_std", "m/s2", 0.01, "noise std of the z2_ddot sensor").bounded(Some(0.0), None),
    ]);
    Descriptor {
        model_identifier: "kalfmu_s1_load",
        model_name: "kalfmu S1 load identification",
        description: "Identifies the dynamic load on a 2-DOF nonlinear spring-damper chain from the accelerations of both masses",
        documentation: "<p>Study S1: Gong, Chen, Li, Wang, <i>Dynamic load identification method for multi-degree-of-freedom \
         nonlinear systems based on SRCKF</i>, J. Xihua Univ. 43(1), 2024. Two masses in series, \
         ground —(k1, c1)— m1 —(k2, c2)— m2, the load F on the free mass m2; k1 and c1 are continuous \
         piecewise-linear laws of three slopes (set equal slopes for a linear element). The estimator \
         augments the state with F as a second-order random walk and runs one predict + update per sample \
         time on the two measured accelerations.</p>\
         <p>Defaults: Table 1 of the paper (stiffness-nonlinear chain).</p>",
        variables: v,
        default_experiment: DefaultExperiment { start: 0.0, stop: 10.0, step: 0.005 },
        build_filter: build,
        build_noise: noise,
        default_filter: FilterKind::SrCkf,
        supervision: SupervisorSettings { wiring_sigmas: 8.0, ..SupervisorSettings::default() },
        derive: no_derived_outputs,
        build_steps: no_quantized_steps,
        unknown_inputs: &Oscillator2DofLoad::UNKNOWN_INPUTS,
        plausible_bound: bound_from_prior,
        smoothed_states: &Oscillator2DofLoad::UNKNOWN_INPUTS,
        guid: String::new(),
    }
    .finish()
}

/// The chain's parameters, starting at the paper's stiffness-nonlinear chain (Table 1);
/// the plant FMU of S1 has the same.
pub(crate) fn chain_variables() -> Vec<Variable> {
    let chain = Oscillator2Dof::stiffness_nonlinear();
    let positive = |var: Variable| var.bounded(Some(0.0), None);
    vec![
        positive(Variable::parameter("m1", "kg", chain.m1, "mass 1")),
        positive(Variable::parameter("m2", "kg", chain.m2, "mass 2")),
        Variable::parameter("k11", "N/m", 5.0, "ground spring: slope up to delta1"),
        Variable::parameter("k12", "N/m", 20.0, "ground spring: slope from delta1 to delta2"),
        Variable::parameter("k13", "N/m", 30.0, "ground spring: slope beyond delta2"),
        positive(Variable::parameter("delta1", "m", 0.1, "ground spring: first breakpoint")),
        positive(Variable::parameter("delta2", "m", 0.2, "ground spring: second breakpoint")),
        Variable::parameter("c11", "N.s/m", 5.0, "ground damper: slope up to eps1"),
        Variable::parameter("c12", "N.s/m", 5.0, "ground damper: slope from eps1 to eps2"),
        Variable::parameter("c13", "N.s/m", 5.0, "ground damper: slope beyond eps2"),
        positive(Variable::parameter("eps1", "m/s", 0.05, "ground damper: first breakpoint")),
        positive(Variable::parameter("eps2", "m/s", 0.10, "ground damper: second breakpoint")),
        Variable::parameter("k2", "N/m", chain.k2, "coupling stiffness"),
        Variable::parameter("c2", "N.s/m", chain.c2, "coupling damping"),
    ]
}

fn law(p: &Parameters, slopes: [&str; 3], breaks: [&str; 2]) -> Result<PiecewiseLinear, String> {
    let s = [p.finite(slopes[0])?, p.finite(slopes[1])?, p.finite(slopes[2])?];
    let b = [p.non_negative(breaks[0])?, p.non_negative(breaks[1])?];
    PiecewiseLinear::new(s, b).map_err(|e| e.to_string())
}

/// The chain of the parameters `m1` … `c2` (the plant FMU of S1 has the same).
pub(crate) fn chain(p: &Parameters) -> Result<Oscillator2Dof, String> {
    Ok(Oscillator2Dof {
        m1: p.positive("m1")?,
        m2: p.positive("m2")?,
        k1: law(p, ["k11", "k12", "k13"], ["delta1", "delta2"])?,
        c1: law(p, ["c11", "c12", "c13"], ["eps1", "eps2"])?,
        k2: p.finite("k2")?,
        c2: p.finite("c2")?,
    })
}

fn build(
    p: &Parameters,
    kind: FilterKind,
    ukf: UnscentedParams,
    noise: Noise,
) -> Result<Box<dyn StateEstimator>, String> {
    let chain = chain(p)?;
    let substeps = p.positive("rk4_substeps")? as usize;
    let mean: Vec<f64> = ["x0_z1", "x0_z2", "x0_F", "x0_z1_dot", "x0_z2_dot", "x0_F_dot"]
        .iter()
        .map(|n| p.finite(n))
        .collect::<Result<_, _>>()?;
    let std: Vec<f64> = ["p0_z1_std", "p0_z2_std", "p0_F_std", "p0_z1_dot_std", "p0_z2_dot_std", "p0_F_dot_std"]
        .iter()
        .map(|n| p.non_negative(n))
        .collect::<Result<_, _>>()?;
    let variances: Vec<f64> = std.iter().map(|s| s * s).collect();
    let prior = Gaussian::diagonal(&mean, &variances);
    let model = Discretized::rk4(Oscillator2DofLoad::new(chain), substeps);
    build_filter(kind, model, noise, &prior, ukf).map_err(|e| e.to_string())
}

/// `Q` over `dt`: the per-sample position and velocity variances scale with
/// `dt / sample_time` (white noise), the load block is the exact discretisation.
fn noise(p: &Parameters, dt: f64) -> Result<Noise, String> {
    let fraction = dt / p.positive("sample_time")?;
    let (qz, qv, q) =
        (p.non_negative("q_z_std")?, p.non_negative("q_z_dot_std")?, p.non_negative("load_noise_intensity")?);
    let mut m = DMatrix::zeros(6, 6);
    for i in [0, 1] {
        m[(i, i)] = qz * qz * fraction;
        m[(i + 3, i + 3)] = qv * qv * fraction;
    }
    m[(2, 2)] = q * dt.powi(3) / 3.0;
    m[(2, 5)] = q * dt.powi(2) / 2.0;
    m[(5, 2)] = m[(2, 5)];
    m[(5, 5)] = q * dt;
    let r = [p.non_negative("r_z1_ddot_std")?, p.non_negative("r_z2_ddot_std")?];
    let r = DMatrix::from_diagonal(&DVector::from_column_slice(&[r[0] * r[0], r[1] * r[1]]));
    Noise::new(m, r).map_err(|e| e.to_string())
}

//! Writes `modelDescription.xml` and `documentation/index.html` from an
//! FMU's description (an estimator's [`Descriptor`], a plant's [`PlantDescriptor`]). Written by hand because `fmi-schema` cannot
//! write units, bounds or enumeration types; a test parses the result back
//! with `fmi-schema` and compares it with the committed files.

use std::fmt::Write as _;

use crate::catalogue::FmuDescription;
use crate::estimators::Descriptor;
use crate::instance::LOG_CATEGORIES;
use crate::plants::PlantDescriptor;
use crate::variables::{Causality, Kind, Role, Variability, Variable, UNITS};

/// The `modelDescription.xml` of an FMU.
pub fn model_description(d: &dyn FmuDescription) -> String {
    let mut x = String::new();
    let _ = writeln!(x, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        x,
        r#"<fmiModelDescription fmiVersion="2.0" modelName="{}" guid="{}" description="{}" generationTool="kalfmu {}" variableNamingConvention="flat" numberOfEventIndicators="0">"#,
        esc(d.model_name()),
        d.guid(),
        esc(d.description()),
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(
        x,
        r#"  <CoSimulation modelIdentifier="{}" canHandleVariableCommunicationStepSize="true" canGetAndSetFMUstate="true" canSerializeFMUstate="true" canNotUseMemoryManagementFunctions="true"/>"#,
        d.model_identifier()
    );
    x.push_str("  <UnitDefinitions>\n");
    for unit in UNITS.iter().filter(|u| d.variables().iter().any(|v| v.unit == Some(u.name))) {
        let [kg, m, s, rad] = unit.exponents;
        let mut base = String::new();
        for (name, e) in [("kg", kg), ("m", m), ("s", s), ("rad", rad)] {
            if e != 0 {
                let _ = write!(base, r#" {name}="{e}""#);
            }
        }
        let _ = writeln!(x, r#"    <Unit name="{}"><BaseUnit{base}/></Unit>"#, esc(unit.name));
    }
    x.push_str("  </UnitDefinitions>\n");
    let enumerations = d.enumeration_types();
    if !enumerations.is_empty() {
        x.push_str("  <TypeDefinitions>\n");
        for t in enumerations {
            let _ = writeln!(x, r#"    <SimpleType name="{}">"#, esc(t.name));
            x.push_str("      <Enumeration>\n");
            for (value, name, description) in t.items {
                let _ = writeln!(
                    x,
                    r#"        <Item name="{}" value="{value}" description="{}"/>"#,
                    esc(name),
                    esc(description)
                );
            }
            x.push_str("      </Enumeration>\n    </SimpleType>\n");
        }
        x.push_str("  </TypeDefinitions>\n");
    }
    x.push_str("  <LogCategories>\n");
    for (name, description) in LOG_CATEGORIES {
        let _ = writeln!(x, r#"    <Category name="{name}" description="{}"/>"#, esc(description));
    }
    x.push_str("  </LogCategories>\n");
    let e = d.default_experiment();
    let _ =
        writeln!(x, r#"  <DefaultExperiment startTime="{}" stopTime="{}" stepSize="{}"/>"#, e.start, e.stop, e.step);
    x.push_str("  <ModelVariables>\n");
    for (vr, v) in d.variables().iter().enumerate() {
        let _ = writeln!(x, "    <!-- index {} -->", vr + 1);
        let initial = match v.causality {
            Causality::Output => r#" initial="calculated""#,
            Causality::Parameter => r#" initial="exact""#,
            Causality::Input => "",
        };
        let _ = writeln!(
            x,
            r#"    <ScalarVariable name="{}" valueReference="{vr}" description="{}" causality="{}" variability="{}"{initial}>"#,
            esc(&v.name),
            esc(v.description),
            causality(v),
            variability(v)
        );
        let _ = writeln!(x, "      {}", type_element(v));
        x.push_str("    </ScalarVariable>\n");
    }
    x.push_str("  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n");
    let indices = |causality: Causality| -> Vec<usize> {
        d.variables().iter().enumerate().filter(|(_, v)| v.causality == causality).map(|(i, _)| i + 1).collect()
    };
    let outputs = indices(Causality::Output);
    // An estimator's every output is the estimate given the measurements up to the
    // time it is read, so it depends on every input of that time: direct feedthrough
    // (the controls too, through the observation h(x, u) of the update at that time).
    // A plant's outputs are those of the time read, under the inputs held from then.
    let inputs: Vec<String> = indices(Causality::Input).iter().map(usize::to_string).collect();
    for i in &outputs {
        let _ = writeln!(x, r#"      <Unknown index="{i}" dependencies="{}"/>"#, inputs.join(" "));
    }
    x.push_str("    </Outputs>\n    <InitialUnknowns>\n");
    for i in &outputs {
        let _ = writeln!(x, r#"      <Unknown index="{i}"/>"#);
    }
    x.push_str("    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n");
    x
}

fn causality(v: &Variable) -> &'static str {
    match v.causality {
        Causality::Parameter => "parameter",
        Causality::Input => "input",
        Causality::Output => "output",
    }
}

fn variability(v: &Variable) -> &'static str {
    match v.variability {
        Variability::Fixed => "fixed",
        Variability::Tunable => "tunable",
        Variability::Discrete => "discrete",
        Variability::Continuous => "continuous",
    }
}

fn type_element(v: &Variable) -> String {
    let mut attrs = String::new();
    if let Kind::Enumeration(t) = v.kind {
        let _ = write!(attrs, r#" declaredType="{}""#, esc(t.name));
    }
    if let Some(unit) = v.unit {
        let _ = write!(attrs, r#" unit="{}""#, esc(unit));
    }
    if let Some(min) = v.min {
        let _ = write!(attrs, r#" min="{}""#, number(v, min));
    }
    if let Some(max) = v.max {
        let _ = write!(attrs, r#" max="{}""#, number(v, max));
    }
    if let Some(start) = v.start {
        let _ = write!(attrs, r#" start="{}""#, number(v, start));
    }
    let tag = match v.kind {
        Kind::Real => "Real",
        Kind::Integer => "Integer",
        Kind::Boolean => "Boolean",
        Kind::Enumeration(_) => "Enumeration",
    };
    format!("<{tag}{attrs}/>")
}

fn number(v: &Variable, x: f64) -> String {
    match v.kind {
        Kind::Real => format!("{x:?}"),
        Kind::Integer | Kind::Enumeration(_) => format!("{}", x as i64),
        Kind::Boolean => (if x != 0.0 { "true" } else { "false" }).to_string(),
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;").replace('\'', "&apos;")
}

/// How the FMU treats time, for `documentation/index.html` (the rules of `timing.rs`).
/// A `{name}` is the variable `name` with its default (see [`documentation`]).
const TIMING: &str = concat!(
    "<p>The filter runs one predict + update per {sample_time} on the grid t<sub>k</sub> = start + ",
    "k·sample_time (counted, never accumulated). The parameter {input_timing} says when the inputs set before ",
    "fmi2DoStep(t, h) were measured. With 1 (<code>communication_point</code>), an input set at communication ",
    "point t is the measurement at t, as FMI defines it: a master sets the plant's outputs of t, calls ",
    "fmi2DoStep(t, h), and reads our outputs.</p>\n",
    "<pre>\n",
    " master:  set u(t)    get y        fmi2DoStep(t, h)          get y         set u(t+h)    get y\n",
    " FMU:               x̂(t | t)     update at t with u(t),    x̂(t+h | t)                  x̂(t+h | t+h)\n",
    "                                 predict to t + h\n",
    "          └ direct feedthrough ┘                                         └ direct feedthrough ┘\n",
    "</pre>\n<ul>\n",
    "<li>A read always gives the estimate at the time read, with its standard deviation. Once an input is set ",
    "at t (a sample instant), outputs read at t are the estimate given the measurements up to t (direct ",
    "feedthrough, declared in ModelStructure). Read right after fmi2DoStep(t, h), before inputs are set at ",
    "t + h, they are the estimate at t + h predicted from the measurements up to t.</li>\n",
    "<li>A measurement is used once: the update at t is made when the master steps on from t (or at a read ",
    "after the inputs were set, and redone from the prediction if they are set again before the step).</li>\n",
    "<li>Samples strictly inside a communication step longer than <code>sample_time</code> are predictions: the ",
    "input held over the step is the measurement of its start, not of later instants.</li>\n",
    "<li>A communication point off the grid (a step shorter than <code>sample_time</code>, or not a multiple of ",
    "it) is not a sample instant: inputs set there are not measurements, and outputs read there are the ",
    "prediction from the last sample to that time (with the process noise of that interval). A warning says so ",
    "once. A master that steps by a multiple of <code>sample_time</code> has every sample it hands over used.</li>\n",
    "<li>A measurement input never set is missing, not zero. A NaN or infinite measurement leaves its row out of ",
    "the update, is counted in <code>skipped_measurements</code> and reported once per input.</li>\n",
    "<li><code>input_timing</code> = 2 (<code>step_end</code>) is for masters that step the plant first and hand ",
    "over its outputs of t + h before our fmi2DoStep(t, h) (Gauss–Seidel): those inputs are the measurement at ",
    "t + h, the step updates there, and the outputs after the step are x̂(t+h | t+h); setting inputs does not ",
    "change the outputs.</li>\n",
    "<li>Whether <code>input_timing</code> fits the master shows in the output <code>input_timing_check</code> ",
    "(Enumeration <code>InputTimingCheck</code>). Masters that propagate initial values (fmpy's simulate_fmu, ",
    "OMSimulator, SSP runners) set the plant's outputs of the start time t<sub>0</sub> on the inputs in ",
    "initialisation mode. Before the first fmi2DoStep(t<sub>0</sub>, h) a Jacobi master sets them again, or ",
    "nothing; a Gauss–Seidel master has stepped the plant and sets its outputs of t<sub>0</sub> + h. The FMU ",
    "compares the inputs set in initialisation mode with those standing at the first step, bit for bit (two NaN ",
    "are the same): different, the master is Gauss–Seidel; the same, it is Jacobi once the inputs set before the ",
    "second step differ from them (inputs that stand still, a plant at rest, say nothing). 1 (<code>fits</code>) ",
    "when that is the <code>input_timing</code> set; 2 (<code>other_fits</code>) when it is the other, with one ",
    "warning naming <code>input_timing</code> and the value to set; 0 (<code>undecided</code>) before, and for good ",
    "when no input was set in initialisation mode or the inputs stood still. The measurements themselves cannot ",
    "tell: the models do not depend on time, so the two orderings make the same filter from priors one step apart. ",
    "A master that sets placeholders in initialisation mode, not the plant's outputs, looks Gauss–Seidel. The FMU ",
    "state holds the check.</li>\n",
    "<li>A filter failure returns fmi2Discard with the time and the reason; the outputs stay at the last good ",
    "estimate, whose time <code>fmi2GetRealStatus(fmi2LastSuccessfulTime)</code> gives.</li>\n</ul>",
);

/// The fixed-lag smoothed outputs, for `documentation/index.html` (rule 9 of `timing.rs`).
const SMOOTHING: &str = concat!(
    "<p>The outputs <code>&lt;name&gt;_smoothed</code> and <code>&lt;name&gt;_smoothed_std</code> (one pair for ",
    "each quantity the FMU is there to estimate) give that quantity <code>smoothing_lag</code> seconds back, ",
    "estimated from the measurements up to the time read: a fixed-lag Rauch–Tung–Striebel smoother on the filter's ",
    "own predictions (its points, or the EKF's Jacobian), with what the gate did at each sample (a jump or a ",
    "re-acquisition loosens the link to the samples before it, a bias step shifts it). Monitoring that can wait a ",
    "fraction of a second gets an estimate without the filter's lag and with less noise.</p>\n<ul>\n",
    "<li><code>smoothed_time</code> says which time they describe: the time read minus {smoothing_lag}, rounded to ",
    "whole samples on the filter's grid. Until that much time has passed it is the start time; read between samples ",
    "it is the lag before the last sample.</li>\n",
    "<li>With <code>smoothing_lag</code> = 0 (off) they are the filter's estimate of the time read, and ",
    "<code>smoothed_time</code> is that time.</li>\n",
    "<li>The same time rules hold as for the estimates: once the inputs of a sample instant t are set, a read at t ",
    "includes the update at t (direct feedthrough); read right after fmi2DoStep(t, h), the prediction to t + h is ",
    "the newest step.</li>\n",
    "<li>Memory is fixed at fmi2ExitInitializationMode: for L = smoothing_lag / sample_time samples, n states and p ",
    "smoothed quantities, (L + 1)·((n + 2)·p + 1) numbers (at most 256 MiB, else the FMU refuses the lag). A ",
    "step allocates nothing and costs about 2·p·n² multiply-adds per sample of the lag. The FMU state holds it.</li>\n",
    "<li>Should a step's predicted covariance be singular, the smoother starts again at that sample (a warning says ",
    "so) and <code>smoothed_time</code> shows it.</li>\n</ul>\n",
);

/// How controls are timed, for the `documentation/index.html` of an FMU with controls
/// (rules 5–8 of `timing.rs`); [`documentation`] appends the controls' start values.
const CONTROLS_TIMING: &str = concat!(
    "<p><b>Controls.</b> The control inputs are known inputs of the model (e.g. rudder deflections), not ",
    "measurements. They are held, as a control computer outputs them: the controls of time τ are in force from τ ",
    "until the communication point whose controls come next. The filter samples them on its grid, as it does the ",
    "measurements: the controls in force at a sample instant t<sub>k</sub> enter the update at t<sub>k</sub> (the ",
    "observation h(x, u(t<sub>k</sub>))) and the prediction from t<sub>k</sub> to t<sub>k+1</sub>.</p>\n<ul>\n",
    "<li>With <code>input_timing</code> = 1 the controls set at t are those of t, held over [t, t+h): they enter ",
    "the update at t (at the step, or at a read after inputs were set at t: setting a control counts as setting ",
    "an input) and the prediction from every sample in [t, t+h). A prediction from a sample before t (a step that ",
    "starts off the grid) keeps the controls in force at that sample.</li>\n",
    "<li>With <code>input_timing</code> = 2 (<code>step_end</code>) everything set before fmi2DoStep(t, h) is of ",
    "t + h, the controls too: they enter the update at t + h and the predictions from t + h on (at the next ",
    "step); the predictions inside the step use the controls of t, set before the previous step (at the first ",
    "step: those standing at fmi2ExitInitializationMode, set in initialisation mode, or their start values).</li>\n",
    "<li>The controls in force are part of the FMU state, which restores them bit for bit.</li>\n",
    "<li>A control is never missing: fmi2SetReal refuses a NaN or infinite control with fmi2Error and changes ",
    "nothing. A control never set is its start value: ",
);

/// Gross errors and the health flags, for `documentation/index.html` (`estimator::Supervisor`).
/// `{gate_sigmas}` says how wide the default gate is (see [`documentation`]).
const SUPERVISION: &str = concat!(
    "<p>Every update goes through a supervisor (the estimation library's <code>SupervisedFilter</code>, as in every study):</p>\n<ul>\n",
    "<li><b>Gate.</b> A measurement row whose normalised innovation ν²/S exceeds the χ²(1) quantile of ",
    "{gate_probability} is left out of that update, exactly as a missing one, and counted in ",
    "<code>rejected_measurements</code>; so is the worst row when the rows kept fail together. ",
    "<code>gate_probability</code> = 1 turns the gate off{gate_sigmas}.</li>\n",
    "<li><b>Stuck.</b> An input that repeats its value bit for bit {stuck_after} times is left out until it ",
    "changes: a live sensor has noise.</li>\n",
    "<li><b><code>&lt;input&gt;_fault</code></b> is true while the input's last {fault_after} samples were all ",
    "rejected, stuck or missing, and false again at the first sample it passes. Each change is logged once, with ",
    "the input and the time.</li>\n",
    "<li><b><code>&lt;input&gt;_status</code></b> (Enumeration <code>InputStatus</code>, one per measurement input) ",
    "says what became of the input in the update the outputs show: 1 <code>used</code>, 2 <code>rejected</code> by ",
    "the gate, 3 <code>missing</code> (NaN, infinite or never set), 4 <code>stuck</code>. Read after the inputs of a ",
    "sample instant t are set, it is that of the update at t (direct feedthrough); after a step, that of the latest ",
    "update (with <code>input_timing</code> = 1 the one at the step's start, with 2 the one at its end); read between ",
    "samples (a prediction, no measurement enters) also that of the latest update; before the first update every ",
    "input is <code>missing</code>. A single gross error shows here at its sample, where ",
    "<code>&lt;input&gt;_fault</code> needs <code>fault_after</code> bad samples in a row. The FMU state holds ",
    "them.</li>\n",
    "<li><b>Jumps.</b> With {take_jumps}, an input failing the gate that a jump of the unknown inputs explains, ",
    "and the other inputs do not contradict, is used from a covariance widened in their directions: the change ",
    "(a load step, an impact) is followed at once. When one input alone explains it, one sample cannot tell a ",
    "spike from a step: the next sample reviews it, a spike is retracted (counted as rejected) and a step kept. ",
    "Meanwhile the outputs show the jump where {show_single_row_jumps} is 1, or hold the estimate before it where ",
    "it is 0, with a σ that covers both readings; within {change_memory} samples of a confirmed jump of that input ",
    "a further one is shown at once (an impact rings). A confirmed jump's other reading (that input wrong) is ",
    "weighed on the samples after it, and the jump is undone, and logged, if that reading explains them better.",
    "</li>\n",
    "<li><b>Re-acquisition.</b> An input failing the gate {reacquire_after} samples in a row makes the filter ",
    "inflate its covariance and update with every input, so that the gate cannot lock it out of a true change (a ",
    "load step); if that input fails again within {consistency_window} samples it was the sensor, and it triggers ",
    "no more until it passes. Every input failing <code>reacquire_after</code> samples in a row re-acquires ",
    "regardless. Each re-acquisition is logged. Together they multiply the covariance by at most {max_inflation} ",
    "until a sample passes the gate with no input rejected: a filter whose sensors are far noisier than their ",
    "<code>r_&lt;input&gt;_std</code> says cannot be brought to agree with them, and further inflation would only ",
    "drive its covariance to overflow. It then updates with the inputs that pass the gate and predicts only while ",
    "none does (unhealthy); the spent budget is logged once.</li>\n",
    "<li><b><code>filter_healthy</code></b> is false while the filter is inconsistent (the normalised innovations of ",
    "the last <code>consistency_window</code> samples, each clipped at the gate, exceed {consistency_margin} ",
    "times their χ² bound: its σ no longer covers the errors its innovations reveal), while every input is rejected, ",
    "and for good once the filter has failed (fmi2Discard). It is true again when the window is back within bound; ",
    "both changes are logged. An input that fails the gate for a whole window makes the filter inconsistent too: ",
    "from the data alone it cannot tell whether that sensor or the estimate is wrong.</li>\n</ul>",
);

/// The names between braces in a documentation text: each `{name}` is written as
/// `<code>name</code> (default X unit)` from the variable's start value, so that no
/// shipped text states a default of its own.
pub fn mentioned_variables(text: &str) -> impl Iterator<Item = &str> {
    text.split('{').skip(1).filter_map(|rest| rest.split_once('}').map(|(name, _)| name))
}

/// `text` with every `{name}` written out as the variable `name` of `d` and its default,
/// or as the phrase `computed` gives for that name.
///
/// # Panics
/// If a name is neither in `computed` nor one of `d`'s variables with a start value:
/// [`crate::estimators::check`] rejects such an estimator documentation.
fn expand(text: &str, d: &dyn FmuDescription, computed: &[(&str, &str)]) -> String {
    let mut out = String::with_capacity(text.len() + 256);
    let mut rest = text;
    while let Some((before, after)) = rest.split_once('{') {
        out.push_str(before);
        let (name, tail) = after.split_once('}').unwrap_or_else(|| panic!("unclosed '{{' in {}", d.model_identifier()));
        if let Some((_, phrase)) = computed.iter().find(|(key, _)| *key == name) {
            out.push_str(phrase);
        } else {
            let v = d.variables().iter().find(|v| v.name == name && v.start.is_some()).unwrap_or_else(|| {
                panic!("the documentation of {} names no parameter or input {name}", d.model_identifier())
            });
            out.push_str(&with_default(v));
        }
        rest = tail;
    }
    out.push_str(rest);
    out
}

/// `<code>name</code> (default X unit)`: the one way the shipped texts state a default
/// (`tests/model_description.rs` parses it back and compares it with the start value).
fn with_default(v: &Variable) -> String {
    let start = v.start.unwrap_or(f64::NAN);
    let value = match v.kind {
        Kind::Real => readable(start),
        Kind::Integer | Kind::Boolean => number(v, start),
        Kind::Enumeration(t) => {
            let item = t.items.iter().find(|(value, _, _)| f64::from(*value) == start);
            match item {
                Some((_, item, _)) => format!("{}, <code>{}</code>", number(v, start), esc(item)),
                None => number(v, start),
            }
        }
    };
    let unit = match v.unit {
        Some(unit) if unit != "1" && v.kind == Kind::Real => format!(" {}", esc(unit)),
        _ => String::new(),
    };
    format!("<code>{}</code> (default {value}{unit})", esc(&v.name))
}

/// `x` as a reader writes it, and exactly (the shortest digits that read back as `x`):
/// `0.02`, `980`, `1e8`, `5e-5`.
fn readable(x: f64) -> String {
    if x == 0.0 || (1e-3..1e6).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// `; the default is a gate at about zσ` for the default `gate_probability` of `d`
/// (nothing when it turns the gate off).
fn gate_sigmas_phrase(d: &Descriptor) -> String {
    let p = d.supervision.gate_probability;
    if p > 0.0 && p < 1.0 {
        format!("; the default is a gate at about {:.1}σ", gate_sigmas(p))
    } else {
        String::new()
    }
}

/// The z a Gaussian innovation lies beyond with probability `1 − p` (two-sided): the
/// gate of `gate_probability` p in standard deviations, for `0 < p < 1`.
fn gate_sigmas(p: f64) -> f64 {
    // Bisection on the two-sided tail erfc(z/√2), which falls in z.
    let (mut lo, mut hi) = (0.0_f64, 40.0_f64);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if erfc(mid / std::f64::consts::SQRT_2) > 1.0 - p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The complementary error function, to a relative error below 1.2e-7 (the Chebyshev
/// fit of Numerical Recipes, `erfcc`): enough for a σ written with one decimal.
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = [
        -1.265_512_23,
        1.000_023_68,
        0.374_091_96,
        0.096_784_18,
        -0.186_288_06,
        0.278_868_07,
        -1.135_203_98,
        1.488_515_87,
        -0.822_152_23,
        0.170_872_77,
    ]
    .iter()
    .rev()
    .fold(0.0, |acc, c| c + t * acc);
    let r = t * (-z * z + poly).exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// `documentation/index.html`: the study, the time semantics, and a table of
/// every variable. Every default the text states is written from the variable's start
/// value in `d`'s table (a `{name}` in the texts, see [`mentioned_variables`]).
pub fn documentation(d: &Descriptor) -> String {
    let controls = if d.control_dim() > 0 {
        let starts: Vec<String> =
            d.variables.iter().filter(|v| matches!(v.role, Role::Control(_))).map(with_default).collect();
        format!("{CONTROLS_TIMING}{}.</li>\n</ul>\n", starts.join(", "))
    } else {
        String::new()
    };
    let mut h = page_head(d, &expand(d.documentation, d, &[]));
    let _ = write!(
        h,
        "<h2>Time: which measurement, which estimate</h2>\n{timing}\n{controls}\
         <h2>Smoothed outputs</h2>\n{smoothing}\
         <h2>Gross errors, faults and health</h2>\n{supervision}\n\
         <p>Fixed parameters (the model, the filter method, the prior, the sample time) can be set until \
         fmi2ExitInitializationMode; tunable parameters (the noise) also between steps, and take effect from the next read or step. \
         The FMU state (fmi2GetFMUstate, fmi2SerializeFMUstate) is pointer-free and restores exactly in a new instance.</p>\n",
        timing = expand(TIMING, d, &[]),
        smoothing = expand(SMOOTHING, d, &[]),
        supervision = expand(SUPERVISION, d, &[("gate_sigmas", &gate_sigmas_phrase(d))]),
    );
    variable_tables(&mut h, &d.variables);
    h
}

/// `documentation/index.html` of a plant: what it is, and a table of every variable.
/// Every default the text states is written from the variable's start value.
pub fn plant_documentation(d: &PlantDescriptor) -> String {
    let mut h = page_head(d, &expand(d.documentation, d, &[]));
    h.push_str(
        "<p>Its inputs are held from the communication point they are set at over the step; its outputs are \
         those of the time read, under the inputs standing then (direct feedthrough). Every parameter is fixed \
         at fmi2ExitInitializationMode. The FMU state (fmi2GetFMUstate, fmi2SerializeFMUstate) is pointer-free \
         and restores exactly in a new instance: the plant and its noise stream.</p>\n",
    );
    variable_tables(&mut h, &d.variables);
    h
}

/// The page's head, title and first section (`study`, HTML).
fn page_head(d: &dyn FmuDescription, study: &str) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{name}</title>\
         <style>body{{font-family:sans-serif;max-width:60em;margin:2em auto}}table{{border-collapse:collapse}}\
         td,th{{border:1px solid #ccc;padding:0.2em 0.5em;text-align:left}}</style></head><body>\n\
         <h1>{name}</h1>\n<p>{description}. FMI 2.0 Co-Simulation, model identifier <code>{id}</code>, GUID <code>{guid}</code>.</p>\n\
         <h2>The study</h2>\n{study}\n",
        name = esc(d.model_name()),
        description = esc(d.description()),
        id = d.model_identifier(),
        guid = d.guid(),
    );
    h
}

/// The tables of inputs, outputs and parameters, and the log categories; closes the page.
fn variable_tables(h: &mut String, variables: &[Variable]) {
    for (title, causality) in
        [("Inputs", Causality::Input), ("Outputs", Causality::Output), ("Parameters", Causality::Parameter)]
    {
        let _ = write!(h, "<h2>{title}</h2>\n<table><tr><th>name</th><th>vr</th><th>unit</th><th>type</th>");
        if causality == Causality::Parameter {
            h.push_str("<th>variability</th><th>start</th>");
        }
        h.push_str("<th>description</th></tr>\n");
        for (vr, v) in variables.iter().enumerate().filter(|(_, v)| v.causality == causality) {
            let kind = match v.kind {
                Kind::Real => "Real".to_string(),
                Kind::Integer => "Integer".to_string(),
                Kind::Boolean => "Boolean".to_string(),
                Kind::Enumeration(t) => format!("Enumeration {}", t.name),
            };
            let _ = write!(
                h,
                "<tr><td><code>{}</code></td><td>{vr}</td><td>{}</td><td>{kind}</td>",
                esc(&v.name),
                esc(v.unit.unwrap_or(""))
            );
            if causality == Causality::Parameter {
                let _ = write!(
                    h,
                    "<td>{}</td><td>{}</td>",
                    variability(v),
                    v.start.map(|s| number(v, s)).unwrap_or_default()
                );
            }
            let _ = writeln!(h, "<td>{}</td></tr>", esc(v.description));
        }
        h.push_str("</table>\n");
    }
    h.push_str("<h2>Log categories</h2>\n<ul>\n");
    for (name, description) in LOG_CATEGORIES {
        let _ = writeln!(h, "<li><code>{name}</code>: {}</li>", esc(description));
    }
    h.push_str("</ul>\n</body></html>\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gate_in_sigmas_is_the_two_sided_gaussian_quantile() {
        // 99.73 % within 3σ, 1 − 1e-6 within 4.8916σ (normal tables).
        assert!((gate_sigmas(0.9973) - 3.0).abs() < 1e-3);
        assert!((gate_sigmas(1.0 - 1e-6) - 4.8916).abs() < 1e-3);
    }

    #[test]
    fn defaults_are_written_exactly_and_readably() {
        for (x, written) in [(0.02, "0.02"), (980.0, "980"), (1e8, "1e8"), (5e-5, "5e-5"), (-25.0, "-25"), (0.0, "0")] {
            assert_eq!(readable(x), written);
            assert_eq!(written.parse::<f64>(), Ok(x));
        }
    }
}

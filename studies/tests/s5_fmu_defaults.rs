//! The S5 FMU's defaults are the study's set-up, so that a user who sets nothing gets the
//! filter the study measures: the prior, the process and sensor noise, the sample time
//! and the airframe. (The FMU crate cannot see the study; the values are copied there.)

use estimator::models::{Airframe, Missile6Dof};
use studies::s5::study::Tuning;
use truth::s5::flight::Settings;

#[test]
fn the_s5_fmus_defaults_are_the_studys_tuning() {
    let d = kalfmu_fmu::estimators::all()
        .into_iter()
        .find(|d| d.model_identifier == "kalfmu_s5_missile")
        .expect("the S5 FMU is among the estimators");
    let start = |name: &str| {
        d.variables.iter().find(|v| v.name == name).and_then(|v| v.start).unwrap_or_else(|| panic!("no default {name}"))
    };
    let tuning = Tuning::new(1.0);
    for (i, name) in Missile6Dof::STATE_NAMES.iter().enumerate() {
        assert_eq!(start(&format!("prior_{name}")), tuning.prior_mean[i], "prior_{name}");
        assert_eq!(start(&format!("prior_{name}_std")), tuning.prior_std[i], "prior_{name}_std");
    }
    for (i, name) in Missile6Dof::MEASUREMENT_NAMES.iter().enumerate() {
        assert_eq!(start(&format!("r_{name}_std")), tuning.sensor_std[i], "r_{name}_std");
    }
    let [v, angle, h, rate] = tuning.motion_std;
    for (name, value) in [
        ("q_velocity_std", v),
        ("q_angle_std", angle),
        ("q_altitude_std", h),
        ("q_rate_std", rate),
        ("q_coefficient_relative_std", tuning.coefficient_relative_std),
        ("sample_time", Settings::default().sample_time),
    ] {
        assert_eq!(start(name), value, "{name}");
    }
    let a = Airframe::tactical_missile();
    assert_eq!(
        [start("mass"), start("area"), start("length"), start("gravity")],
        [a.mass, a.area, a.length, a.gravity]
    );
    assert_eq!([start("inertia_x"), start("inertia_y"), start("inertia_z")], a.inertia);
}

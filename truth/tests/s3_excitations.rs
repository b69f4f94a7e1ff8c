//! The S3 truth under its excitations: a dip of one rail is half a vertical and half a
//! cross-level input, the alignment loads the wheels' difference, a twist unloads a
//! diagonal, the integration step is small enough, and the cases come out as named.

use truth::s3::cases::{self, Case, Settings as CaseSettings};
use truth::s3::irregularity::Irregularity;
use truth::s3::parameters::{Track, Vehicle};
use truth::s3::plant::{Settings, Simulation};

/// The eight contact forces (left 1–4, right 1–4) at every step of a run of `seconds` over
/// `irregularity`.
fn forces(irregularity: Irregularity, settings: &Settings, seconds: f64) -> Vec<[f64; 8]> {
    let mut sim = Simulation::new(Vehicle::PASSENGER, Track::BALLASTED, irregularity, settings).expect("runs");
    let mut out = vec![sim.sample().contact];
    while sim.time() < seconds - 0.5 * settings.dt {
        sim.step();
        out.push(sim.sample().contact);
    }
    out
}

/// The front wheel reaches `at` seconds into the run at 80 km/h.
fn ahead_of_front_wheel(seconds: f64) -> f64 {
    Vehicle::PASSENGER.vertical.wheel_offsets()[0] + 80.0 / 3.6 * seconds
}

fn dip(left: f64, right: f64) -> Irregularity {
    Irregularity::Dip { at: ahead_of_front_wheel(0.1), length: 1.0, left, right }
}

/// A 1 mm dip of the left rail alone is a 0.5 mm dip of both rails plus a ±0.5 mm
/// cross-level. The sum L + R of each wheelset follows the vertical response (the 0.5 mm
/// dip of both rails) to within a few % of its swing, while L − R, nothing on the level
/// dip, swings as much as the sum does.
#[test]
fn a_cross_level_moves_left_against_right_and_leaves_the_sum_to_the_vertical_response() {
    let settings = Settings::default();
    let one_rail = forces(dip(1e-3, 0.0), &settings, 0.5);
    let both = forces(dip(0.5e-3, 0.5e-3), &settings, 0.5);
    let p0 = Vehicle::PASSENGER.static_wheel_load();
    for j in 0..2 {
        let (mut swing, mut sum_error, mut difference, mut level_difference) = (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
        for (a, b) in one_rail.iter().zip(&both) {
            swing = swing.max((b[j] + b[4 + j] - 2.0 * p0).abs());
            sum_error = sum_error.max((a[j] + a[4 + j] - b[j] - b[4 + j]).abs());
            difference = difference.max((a[j] - a[4 + j]).abs());
            level_difference = level_difference.max((b[j] - b[4 + j]).abs());
        }
        eprintln!(
            "wheelset {}: L + R swings {swing:.0} N on the level dip, differs by {sum_error:.0} N on the one-rail dip; \
             L − R {difference:.0} N (level dip: {level_difference:.1e} N)",
            j + 1
        );
        assert!(sum_error < 0.05 * swing, "sum differs by {sum_error} N of a {swing} N swing");
        assert!(difference > 0.5 * swing, "L − R {difference} N against a {swing} N swing");
        assert!(level_difference < 1e-6 * swing, "level dip L − R {level_difference} N");
    }
}

/// Halving Δt (1e-4 s to 5e-5 s) moves the peak (and the least) force of every wheel over
/// the dipped joint by under 1 %.
#[test]
fn halving_the_step_changes_the_peak_forces_by_under_one_percent() {
    let joint = || Irregularity::dipped_joint(ahead_of_front_wheel(0.1));
    let coarse = forces(joint(), &Settings::default(), 1.1);
    let fine = forces(joint(), &Settings { dt: 5e-5, ..Settings::default() }, 1.1);
    let p0 = Vehicle::PASSENGER.static_wheel_load();
    let mut worst = 0.0_f64;
    for k in 0..8 {
        let peak = |run: &[[f64; 8]]| run.iter().fold(0.0_f64, |m, f| m.max(f[k]));
        let least = |run: &[[f64; 8]]| run.iter().fold(f64::MAX, |m, f| m.min(f[k]));
        let (peak_change, least_change) = (peak(&fine) / peak(&coarse) - 1.0, least(&fine) / least(&coarse) - 1.0);
        eprintln!(
            "{}: peak {:.0} N ({:+.3} %), least {:.0} N ({:+.3} %), dynamic increment {:.0} N",
            cases::CONTACT[k],
            peak(&fine),
            100.0 * peak_change,
            least(&fine),
            100.0 * least_change,
            peak(&fine) - p0
        );
        worst = worst.max(peak_change.abs()).max(least_change.abs());
    }
    assert!(worst < 0.01, "{worst}");
}

/// A wheel over a short deep dip of its rail (2 mm over 0.2 m, 9 ms at 80 km/h) cannot
/// follow it: it leaves the rail, carries nothing while it flies, and lands again; its
/// partner on the other rail keeps its contact throughout.
#[test]
fn a_wheel_that_leaves_its_rail_carries_nothing_and_lands_again() {
    let gap = Irregularity::Dip { at: ahead_of_front_wheel(0.1), length: 0.2, left: 2e-3, right: 0.0 };
    let run = forces(gap, &Settings::default(), 0.3);
    let p0 = Vehicle::PASSENGER.static_wheel_load();
    let airborne = run.iter().filter(|f| f[0] == 0.0).count();
    let least_right = run.iter().fold(f64::MAX, |m, f| m.min(f[4]));
    let peak = run.iter().fold(0.0_f64, |m, f| m.max(f[0]));
    let last = run[run.len() - 1];
    eprintln!(
        "F_NL1 zero for {:.1} ms, peak on landing {peak:.0} N; F_NR1 at least {least_right:.0} N; at 0.3 s {:.0} N",
        airborne as f64 * 0.1,
        last[0]
    );
    assert!(airborne > 5, "{airborne} steps without contact");
    assert!(least_right > 0.0);
    assert!(peak > 1.5 * p0);
    assert!((last[0] / p0 - 1.0).abs() < 0.1, "{} N at the end", last[0]);
}

/// The same random track with and without an alignment: the alignment steers the
/// wheelsets, whose lateral forces at rail height move load from one wheel to the other;
/// the sum of a wheelset's loads barely notices. (Without the alignment the wheels already
/// feel lateral forces: the normal forces lean on the cones, and their difference, driven
/// by the cross-level, pushes the wheelset sideways.)
#[test]
fn an_alignment_loads_one_wheel_and_unloads_the_other() {
    let settings = CaseSettings { duration: 2.0, rate: 200.0, ..CaseSettings::default() };
    let plain = cases::simulate(Case::Random, &settings).expect("runs");
    let aligned = cases::simulate(Case::RandomAlignment, &settings).expect("runs");
    let rms = |x: &mut dyn Iterator<Item = f64>| {
        let v: Vec<f64> = x.collect();
        (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
    };
    let pairs = || plain.contact.iter().zip(&aligned.contact);
    for j in 0..4 {
        let sum_change = rms(&mut pairs().map(|(a, b)| b[j] + b[4 + j] - a[j] - a[4 + j]));
        let difference_change = rms(&mut pairs().map(|(a, b)| b[j] - b[4 + j] - a[j] + a[4 + j]));
        let lateral_change = rms(&mut plain
            .lateral_contact
            .iter()
            .zip(&aligned.lateral_contact)
            .map(|(a, b)| b[j] + b[4 + j] - a[j] - a[4 + j]));
        eprintln!(
            "wheelset {}: the alignment changes the lateral force by {lateral_change:.0} N RMS, L − R by \
             {difference_change:.0} N RMS, L + R by {sum_change:.1} N RMS",
            j + 1
        );
        assert!(lateral_change > 50.0, "{lateral_change}");
        assert!(difference_change > 20.0 * sum_change, "{difference_change} against {sum_change}");
    }
}

/// On the twist the front bogie rolls left-down while the rear one is still level: the car
/// body and the bogie frames resist the warp, so the diagonal front left – rear right
/// unloads against the other. (The cross-level also leans the car towards the low left
/// rail, which loads both left wheels alike: the diagonal takes the difference of the two
/// bogies' L − R.)
#[test]
fn a_twist_unloads_a_diagonal() {
    let settings = CaseSettings { duration: 2.2, rate: 200.0, ..CaseSettings::default() };
    let truth = cases::simulate(Case::Twist, &settings).expect("runs");
    // The front wheel meets the ramp at 0.5 s and leaves it 20 m (0.9 s) on; the rearmost
    // wheel, 20.4 m behind, meets it at 1.42 s. At 1.4 s the front bogie is on the full
    // 6 mm and the rear one still level.
    let k = (1.4 * settings.rate).round() as usize;
    let f = truth.contact[k];
    let (front, rear) = (f[0] - f[4], f[3] - f[7]);
    let before = truth.contact[(0.4 * settings.rate).round() as usize];
    eprintln!(
        "twist at 1.4 s: F_L1 − F_R1 = {front:.0} N, F_L4 − F_R4 = {rear:.0} N; diagonal {:.0} N (before: {:.1e} N)",
        front - rear,
        before[0] - before[4] - before[3] + before[7]
    );
    assert!(front - rear < -500.0);
}

#[test]
fn every_case_runs_and_records_its_named_channels() {
    let settings = CaseSettings { duration: 1.5, rate: 200.0, ..CaseSettings::default() };
    // The car that runs is the settings' (the catalogue car as built), not the catalogue.
    let p0 = settings.vehicle.static_wheel_load();
    assert!(p0 > Vehicle::PASSENGER.static_wheel_load());
    for case in Case::ALL {
        assert_eq!(case.name().parse::<Case>(), Ok(case));
        let truth = cases::simulate(case, &settings).expect("runs");
        let n = truth.time.len();
        assert_eq!(n, 301);
        for len in [
            truth.accelerations.len(),
            truth.deflections.len(),
            truth.lateral_accelerations.len(),
            truth.contact.len(),
            truth.lateral_contact.len(),
        ] {
            assert_eq!(len, n);
        }
        let finite = truth.accelerations.iter().flatten().chain(truth.contact.iter().flatten()).all(|x| x.is_finite());
        assert!(finite, "{case}");
        let mean: f64 = truth.contact.iter().flatten().sum::<f64>() / (8 * n) as f64;
        assert!((mean / p0 - 1.0).abs() < 0.01, "{case}: mean wheel load {mean} N");
        let m = cases::measure(&truth, 0.02, 3);
        let channel = 16;
        let rms = (truth.accelerations.iter().map(|a| a[channel] * a[channel]).sum::<f64>() / n as f64).sqrt();
        assert!((m.accelerations_noise_std[channel] - 0.02 * rms).abs() < 1e-12 * rms.max(1.0));
        assert_eq!(m.deflections.len(), n);
    }
    assert_eq!(cases::ACCELERATIONS.len() + cases::DEFLECTIONS.len() + cases::LATERAL_ACCELERATIONS.len(), 32);
    assert!("corrugation".parse::<Case>().is_err());
}

#[test]
fn bad_case_settings_are_refused() {
    for settings in [
        CaseSettings { speed: -1.0, ..CaseSettings::default() },
        CaseSettings { rate: 300.0, ..CaseSettings::default() },
        CaseSettings { noise_fraction: f64::NAN, ..CaseSettings::default() },
        CaseSettings { duration: 0.0, ..CaseSettings::default() },
        CaseSettings { vehicle: Vehicle { conicity: 0.0, ..cases::as_built() }, ..CaseSettings::default() },
    ] {
        assert!(cases::simulate(Case::Joint, &settings).is_err(), "{settings:?}");
    }
}

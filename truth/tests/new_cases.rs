//! The truth cases the estimators were not tuned on: S1's three loads, S2's three track
//! spectra, S5's second manoeuvre and S4's frequent faults. Each test checks the property
//! the case is named for against an independent reading of the data it writes (a
//! periodogram, zero crossings, the formula's closed-form integral, fault counts).

use estimator::math;
use std::f64::consts::TAU;

use truth::s1::load::{Load, Step};
use truth::s1::{self, Case, LoadKind, Nonlinearity, UnseenLoad};
use truth::s2::cases::{self as s2, Scenario};
use truth::s2::irregularity::{FraSpectrum, GermanSpectrum, RandomProfile, Spectrum, TrackSpectrum};
use truth::s2::parameters::Vehicle;
use truth::s4::channels::simulate as record;
use truth::s4::faults::{FaultKind, FaultProfile, Faults};
use truth::s4::profile::Profile;
use truth::s5::flight::{self as s5, simulate_named};
use truth::s5::manoeuvre::Manoeuvre;

/// The one-sided power of `x` (sampled every `dt`) in the band `[lo, hi]` Hz, Hann-windowed
/// and normalised so that the power over all bins is the mean square: a plain DFT at the
/// bins `k/(N·dt)` inside the band.
fn band_power(x: &[f64], dt: f64, lo: f64, hi: f64) -> f64 {
    let n = x.len();
    let window: Vec<f64> = (0..n).map(|j| 0.5 * (1.0 - math::cos(TAU * j as f64 / n as f64))).collect();
    let gain: f64 = window.iter().map(|w| w * w).sum::<f64>();
    let duration = n as f64 * dt;
    let (k0, k1) = ((lo * duration).ceil().max(1.0) as usize, (hi * duration).floor() as usize);
    (k0..=k1.min(n / 2 - 1))
        .map(|k| {
            let (mut re, mut im) = (0.0, 0.0);
            let w = TAU * k as f64 / n as f64;
            // Rotate a phasor rather than calling sin and cos per sample.
            let (c, s) = (math::cos(w), math::sin(w));
            let (mut pc, mut ps) = (1.0, 0.0);
            for (v, h) in x.iter().zip(&window) {
                re += v * h * pc;
                im -= v * h * ps;
                (pc, ps) = (pc * c - ps * s, pc * s + ps * c);
            }
            2.0 * (re * re + im * im) / (gain * n as f64)
        })
        .sum()
}

fn mean_square(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64
}

// --- S1 ------------------------------------------------------------------------------

#[test]
fn s1_band20_load_is_flat_to_20_hz_and_empty_beyond() {
    let ((lo, hi), components) = Load::BAND_20;
    assert_eq!(((lo, hi), components), ((0.2, 20.0), 800));
    let load = Load::band_limited(1, 10.0, (lo, hi), components);
    let dt = 0.01;
    let x = load.tabulate(0.0, dt, 6000); // 60 s at 100 Hz
    let total = band_power(&x, dt, 0.0, 50.0);
    assert!((mean_square(&x).sqrt() - 10.0).abs() < 0.5, "RMS {}", mean_square(&x).sqrt());
    assert!(
        (total / mean_square(&x) - 1.0).abs() < 0.05,
        "the periodogram's normalisation: {total} against {}",
        mean_square(&x)
    );
    let inside = band_power(&x, dt, 0.2, 20.0);
    let beyond = band_power(&x, dt, 20.5, 50.0);
    assert!(inside > 0.99 * total, "power in 0.2–20 Hz: {:.4} of the total", inside / total);
    assert!(beyond < 0.002 * total, "power above 20.5 Hz: {:.5} of the total", beyond / total);
    // Flat: each quarter of the band holds its share of the power.
    for (a, b) in [(0.2, 5.0), (5.0, 10.0), (10.0, 15.0), (15.0, 20.0)] {
        let share = band_power(&x, dt, a, b) / inside;
        let expected = (b - a) / (hi - lo);
        assert!((share / expected - 1.0).abs() < 0.1, "{a}–{b} Hz holds {share:.3}, expected {expected:.3}");
    }
    // The paper's random load has none of this: almost nothing above 10.5 Hz.
    let paper = Load::random(1, 10.0).tabulate(0.0, dt, 6000);
    assert!(band_power(&paper, dt, 10.5, 50.0) < 0.002 * mean_square(&paper));
    // Seeded: the seed decides it, and only the seed.
    let again = Load::band_limited(1, 10.0, (lo, hi), components);
    assert_eq!(again.value(12.345), load.value(12.345));
    assert_ne!(Load::band_limited(2, 10.0, (lo, hi), components).value(12.345), load.value(12.345));
}

#[test]
fn s1_chirp_sweeps_from_0_1_to_15_hz() {
    let duration = 60.0;
    let load = Load::chirp(10.0, Load::CHIRP_BAND, duration);
    let chirp = *load.chirp_part().expect("a chirp");
    assert_eq!((chirp.start, chirp.end, chirp.duration), (0.1, 15.0, 60.0));
    assert!((chirp.frequency(0.0) - 0.1).abs() < 1e-12 && (chirp.frequency(duration) - 15.0).abs() < 1e-9);
    let dt = 1e-4;
    let n = (duration / dt).round() as usize + 1;
    let x = load.tabulate(0.0, dt, n);
    assert_eq!(x[0], 0.0, "the chirp starts at 0, as the chain does");
    assert!((mean_square(&x).sqrt() - 10.0).abs() < 0.1, "RMS {}", mean_square(&x).sqrt());
    // Zero crossings, interpolated; each half period gives the frequency at its middle.
    let mut crossings = vec![0.0];
    for j in 1..n {
        if x[j - 1] != 0.0 && (x[j - 1] < 0.0) != (x[j] < 0.0) {
            crossings.push(dt * ((j - 1) as f64 + x[j - 1] / (x[j - 1] - x[j])));
        }
    }
    let halves: Vec<(f64, f64)> =
        crossings.windows(2).map(|w| (0.5 * (w[0] + w[1]), 1.0 / (2.0 * (w[1] - w[0])))).collect();
    let (first, last) = (halves[0].1, halves[halves.len() - 1].1);
    assert!((0.1..0.13).contains(&first), "the first half period reads {first} Hz");
    assert!((14.5..15.0).contains(&last), "the last half period reads {last} Hz");
    for pair in halves.windows(2) {
        assert!(pair[1].1 > pair[0].1, "the frequency rises: {pair:?}");
    }
    for &(t, f) in &halves[1..] {
        let law = chirp.frequency(t);
        assert!((f / law - 1.0).abs() < 0.01, "at {t:.3} s the signal reads {f} Hz, the law {law} Hz");
    }
    // Ḟ is the derivative of F.
    for t in [0.0, 7.7, 31.4, 59.9] {
        let h = 1e-7;
        let numeric = (load.value(t + h) - load.value(t - h)) / (2.0 * h);
        assert!((numeric - load.rate(t)).abs() < 1e-5 * load.rate(t).abs().max(1.0), "at {t} s");
    }
}

#[test]
fn s1_steps_occur_where_recorded() {
    let (seed, rms, duration) = (1, 10.0, 60.0);
    let load = Load::steps(seed, rms, duration);
    let background = Load::random(seed, rms);
    let steps: Vec<Step> = load.steps_taken().to_vec();
    assert!(steps.len() >= 5, "{} steps", steps.len());
    assert!(steps.iter().any(|s| s.size > 0.0) && steps.iter().any(|s| s.size < 0.0), "both signs: {steps:?}");
    let gaps: Vec<f64> = steps.windows(2).map(|w| w[1].at - w[0].at).collect();
    assert!(gaps.iter().all(|g| (3.0 - 1e-3..=12.0 + 1e-3).contains(g)), "gaps {gaps:?}");
    assert!(gaps.iter().any(|g| (g - gaps[0]).abs() > 0.5), "irregular instants: {gaps:?}");
    assert!(steps[0].at >= 2.0 && steps.last().unwrap().at <= duration - 2.0);
    let mut level = 0.0;
    for s in &steps {
        assert!(s.size.abs() >= rms, "a step of {} N", s.size);
        level += s.size;
        assert!(level.abs() <= 2.5 * rms + 1e-9, "the level reaches {level} N");
    }
    // The load less its background is the recorded staircase, at every millisecond.
    let staircase = |t: f64| steps.iter().filter(|s| s.at + Step::RISE <= t).map(|s| s.size).sum::<f64>();
    let rising = |t: f64| steps.iter().any(|s| (s.at..s.at + Step::RISE).contains(&t));
    for j in 0..=60_000 {
        let t = j as f64 * 1e-3;
        if !rising(t) {
            let d = load.value(t) - background.value(t);
            assert!((d - staircase(t)).abs() < 1e-9, "at {t} s the load is {d} N above its background");
        }
    }
    // And the truth the study writes carries them there: the case `stiffness/steps`.
    let case: Case = "stiffness/steps".parse().unwrap();
    let settings = s1::Settings { duration: 20.0, ..s1::Settings::default() };
    let (truth, _) = s1::simulate(&case, &settings);
    let in_run = Load::steps(settings.seed, settings.load_rms, settings.duration);
    assert!(!in_run.steps_taken().is_empty());
    let m2 = case.chain().m2;
    for s in in_run.steps_taken() {
        let k0 = (s.at / settings.dt()).floor() as usize;
        let k1 = k0 + 3; // 15 ms later, past the 10 ms rise
        let jump = truth.load[k1] - truth.load[k0];
        let background_change = background.value(truth.time[k1]) - background.value(truth.time[k0]);
        assert!((jump - background_change - s.size).abs() < 1e-9, "the step at {} s", s.at);
        // m₂·z̈₂ = F − (coupling), and the coupling does not jump.
        let inertial = m2 * (truth.acceleration[k1][1] - truth.acceleration[k0][1]);
        assert!((inertial - jump).abs() < 0.05 * s.size.abs(), "m2·Δz̈2 {inertial} N against ΔF {jump} N");
    }
}

#[test]
fn s1_unseen_cases_are_named_parsed_and_apart_from_the_papers() {
    let names: Vec<String> = Case::UNSEEN.iter().map(Case::to_string).collect();
    assert_eq!(
        names,
        ["stiffness/band20", "stiffness/steps", "stiffness/chirp", "damping/band20", "damping/steps", "damping/chirp"]
    );
    for case in Case::every() {
        assert_eq!(case.to_string().parse::<Case>(), Ok(case));
    }
    let chirp: Case = "damping/chirp".parse().unwrap();
    assert_eq!(
        chirp,
        Case { nonlinearity: Nonlinearity::Damping, load: LoadKind::Random, unseen: Some(UnseenLoad::Chirp) }
    );
    assert!(!chirp.is_published() && Case::ALL.iter().all(Case::is_published));
    assert_eq!(
        Case::ALL.map(|c| c.to_string()),
        ["stiffness/random", "damping/random", "stiffness/harmonic", "damping/harmonic"]
    );
    let error = "stiffness/sine".parse::<Case>().unwrap_err();
    assert!(error.contains("expected one of stiffness/random") && error.contains("damping/chirp"), "{error}");
    // Each unseen case's load is its own.
    let settings = s1::Settings::default();
    let at = |case: &str| s1::load(&case.parse().unwrap(), &settings).value(33.3);
    let values = ["stiffness/random", "stiffness/band20", "stiffness/steps", "stiffness/chirp"].map(at);
    for i in 0..4 {
        for j in 0..i {
            assert_ne!(values[i], values[j]);
        }
    }
    assert_eq!(at("stiffness/band20"), at("damping/band20"));
}

#[test]
fn s1_unseen_cases_run_with_noise_from_1_to_5_percent() {
    for case in Case::UNSEEN {
        for fraction in [0.01, 0.02, 0.05] {
            let settings = s1::Settings { duration: 10.0, noise_fraction: fraction, ..s1::Settings::default() };
            settings.validate().unwrap();
            let (truth, m) = s1::simulate(&case, &settings);
            assert_eq!(m.acceleration.len(), settings.samples() + 1);
            let rms = truth.acceleration_rms();
            for c in 0..2 {
                assert!(rms[c] > 0.0 && rms[c].is_finite(), "{case}: RMS {rms:?}");
                assert!((m.noise_std[c] - fraction * rms[c]).abs() < 1e-12 * rms[c]);
                let errors: Vec<f64> =
                    m.acceleration.iter().zip(&truth.acceleration).map(|(z, a)| z[c] - a[c]).collect();
                let std = mean_square(&errors).sqrt();
                assert!(
                    (std / m.noise_std[c] - 1.0).abs() < 0.08,
                    "{case} at {fraction}: noise {std} against {}",
                    m.noise_std[c]
                );
            }
            assert!(truth.motion.iter().flatten().all(|v| v.is_finite()), "{case}");
        }
    }
}

// --- S2 ------------------------------------------------------------------------------

/// `∫ S(Ω) dΩ` of the German spectrum between two wavelengths, in closed form:
/// `A·Ωc²/(Ωc² − Ωr²)·[atan(Ω/Ωr)/Ωr − atan(Ω/Ωc)/Ωc]`.
fn german_variance_exact(s: &GermanSpectrum, shortest: f64, longest: f64) -> f64 {
    let (c, r) = (s.cutoff, s.rolloff);
    let primitive = |o: f64| s.roughness * c * c / (c * c - r * r) * (math::atan(o / r) / r - math::atan(o / c) / c);
    primitive(TAU / shortest) - primitive(TAU / longest)
}

#[test]
fn s2_german_spectra_are_the_published_formula() {
    let low = GermanSpectrum::LOW_INTERFERENCE;
    let high = GermanSpectrum::HIGH_INTERFERENCE;
    assert_eq!((low.roughness, low.cutoff, low.rolloff), (4.032e-7, 0.8246, 0.0206));
    assert_eq!((high.roughness, high.cutoff, high.rolloff), (1.080e-6, 0.8246, 0.0206));
    for omega in [0.01, 0.1, 0.8246, 3.0] {
        let formula =
            4.032e-7 * 0.8246f64.powi(2) / ((omega * omega + 0.0206f64.powi(2)) * (omega * omega + 0.8246f64.powi(2)));
        assert!((low.density(omega) / formula - 1.0).abs() < 1e-14);
    }
    for s in [low, high] {
        for (shortest, longest) in [(1.0, 120.0), (2.0, 20.0), (5.0, 50.0)] {
            let exact = german_variance_exact(&s, shortest, longest);
            let simpson = s.variance(shortest, longest);
            assert!((simpson / exact - 1.0).abs() < 1e-8, "{shortest}–{longest} m: {simpson} against {exact}");
            assert_eq!(TrackSpectrum::German(s).variance(shortest, longest), simpson);
            assert_eq!(Spectrum::variance(&s, shortest, longest), simpson);
        }
    }
    // High interference is the rougher track; both are smoother than FRA class 5.
    assert!(low.variance(1.0, 120.0) < high.variance(1.0, 120.0));
    assert!(high.variance(1.0, 120.0) < FraSpectrum::CLASS_5.variance(1.0, 120.0));
}

#[test]
fn s2_german_profiles_have_the_formulas_rms_over_a_wavelength_band() {
    let low = GermanSpectrum::LOW_INTERFERENCE;
    // Over the whole sampled band (1–120 m: the table's RMS) and over 2–20 m (a periodogram
    // of the profile read every 0.25 m), 3 km of track per seed (25 of the longest waves).
    let bands = [(1.0, 120.0), (2.0, 20.0)];
    let seeds = [1, 2, 3, 4];
    // Each seed's 3 km table is the costly part: one thread per seed.
    let measured: Vec<[f64; 2]> = std::thread::scope(|scope| {
        let runs: Vec<_> = seeds
            .iter()
            .map(|&seed| {
                scope.spawn(move || {
                    let profile = RandomProfile::sample(&low, seed, 0.0, 3000.0);
                    let dx = 0.25;
                    let x: Vec<f64> = (0..12_000).map(|i| profile.at(i as f64 * dx)).collect();
                    [profile.rms().powi(2), band_power(&x, dx, 1.0 / 20.0, 1.0 / 2.0)]
                })
            })
            .collect();
        runs.into_iter().map(|run| run.join().unwrap()).collect()
    });
    let mut variances = [0.0; 2];
    for (seed, m) in seeds.iter().zip(&measured) {
        for ((&(shortest, longest), m), sum) in bands.iter().zip(m).zip(&mut variances) {
            let ratio = (m / german_variance_exact(&low, shortest, longest)).sqrt();
            assert!((ratio - 1.0).abs() < 0.06, "seed {seed}, {shortest}–{longest} m: RMS {ratio:.4} of the formula's");
            *sum += m / seeds.len() as f64;
        }
    }
    for (&(shortest, longest), mean) in bands.iter().zip(variances) {
        let expected = german_variance_exact(&low, shortest, longest);
        let ratio = (mean / expected).sqrt();
        assert!(
            (ratio - 1.0).abs() < 0.03,
            "{shortest}–{longest} m over the seeds: {:.4} mm RMS, the formula {:.4} mm",
            mean.sqrt() * 1e3,
            expected.sqrt() * 1e3
        );
    }
    // High interference has low's shape: the same seed draws the same profile, scaled by
    // √(1.080e-6/4.032e-7).
    let a = RandomProfile::sample(&low, 9, 0.0, 200.0);
    let b = RandomProfile::sample(&TrackSpectrum::GERMAN_HIGH, 9, 0.0, 200.0);
    let scale = (1.080e-6f64 / 4.032e-7).sqrt();
    for x in [3.0, 57.31, 150.0] {
        assert!((b.at(x) - scale * a.at(x)).abs() < 1e-12, "at {x} m");
    }
    assert!(b.rms() > a.rms());
}

#[test]
fn s2_fra_class_6_is_smoother_than_class_5() {
    assert_eq!((FraSpectrum::CLASS_6.roughness, FraSpectrum::CLASS_6.cutoff), (0.0339e-4, 0.8245));
    let five = RandomProfile::sample(&FraSpectrum::CLASS_5, 4, 0.0, 200.0);
    let six = RandomProfile::sample(&TrackSpectrum::FRA_6, 4, 0.0, 200.0);
    assert!(six.rms() < five.rms(), "class 6 RMS {} m, class 5 {} m", six.rms(), five.rms());
    // The same seed draws the same phases: the two differ by √(A_v ratio) alone.
    let ratio = (0.0339f64 / 0.2095).sqrt();
    assert!((six.rms() / five.rms() / ratio - 1.0).abs() < 1e-9);
    // Over 3 km (25 of the longest waves), class 6's RMS is its spectrum's.
    let six = RandomProfile::sample(&TrackSpectrum::FRA_6, 4, 0.0, 3000.0);
    let expected = FraSpectrum::CLASS_6.variance(1.0, 120.0).sqrt();
    assert!((six.rms() / expected - 1.0).abs() < 0.1, "class 6: {} m against {} m", six.rms(), expected);
}

#[test]
fn s2_scenarios_and_spectra_are_named_and_parsed() {
    let names: Vec<String> = Scenario::every().map(|s| s.to_string()).collect();
    assert_eq!(names, ["random", "corrugation", "weld", "random/fra6", "random/german-low", "random/german-high"]);
    for scenario in Scenario::every() {
        assert_eq!(scenario.to_string().parse::<Scenario>(), Ok(scenario));
        assert_eq!(scenario.is_published(), Scenario::PAPER.contains(&scenario));
    }
    assert_eq!("random/fra5".parse::<Scenario>(), Ok(Scenario::PAPER[0]));
    for bad in ["random/fra7", "weld/german-low", "german-low", ""] {
        assert!(bad.parse::<Scenario>().is_err(), "{bad}");
    }
    for spectrum in TrackSpectrum::ALL {
        assert_eq!(spectrum.to_string().parse::<TrackSpectrum>(), Ok(spectrum));
    }
    assert_eq!(s2::Settings::default().spectrum, TrackSpectrum::FRA_5);
    let high: Scenario = "random/german-high".parse().unwrap();
    assert_eq!(high.settings(&s2::Settings::default()).spectrum, TrackSpectrum::GERMAN_HIGH);
}

#[test]
fn s2_unseen_tracks_run_from_40_to_160_kmh_at_200_hz_and_1_khz() {
    let as_built = s2::as_built();
    let static_load = as_built.static_wheel_load();
    assert!(static_load > Vehicle::ZHAI_PASSENGER.static_wheel_load());
    let dynamic_std = |truth: &s2::Truth, from: usize| {
        let f: Vec<f64> = truth.contact[from..].iter().map(|c| c[0]).collect();
        let mean = f.iter().sum::<f64>() / f.len() as f64;
        (f.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / f.len() as f64).sqrt()
    };
    for (kmh, rate) in [(40.0, 200.0), (40.0, 1000.0), (160.0, 200.0), (160.0, 1000.0)] {
        let mut spread = Vec::new();
        for scenario in Scenario::UNSEEN {
            let base = s2::Settings { speed: kmh / 3.6, rate, duration: 1.0, ..s2::Settings::default() };
            let settings = scenario.settings(&base);
            settings.validate().unwrap();
            let truth = scenario.simulate(&base);
            assert_eq!(truth.time.len(), (rate * base.duration).round() as usize + 1);
            assert!(truth.accelerations.iter().flatten().chain(truth.contact.iter().flatten()).all(|v| v.is_finite()));
            let from = truth.time.iter().position(|&t| t >= 0.2).unwrap();
            for c in &truth.contact[from..] {
                for f in c {
                    assert!((0.5 * static_load..1.5 * static_load).contains(f), "{scenario} at {kmh} km/h: {f} N");
                }
            }
            let m = s2::measure(&truth, 0.02, base.seed);
            assert!(m.noise_std.iter().all(|s| *s > 0.0 && s.is_finite()));
            spread.push(dynamic_std(&truth, from));
        }
        // fra6, german-low, german-high: the same phases, so the rougher track shakes the
        // wheel more, about as √(A_v) (1.64 from German low to high).
        let (low, high) = (spread[1], spread[2]);
        assert!(high / low > 1.3 && high / low < 2.0, "{kmh} km/h, {rate} Hz: σ {low} N against {high} N");
    }
}

// --- S4 ------------------------------------------------------------------------------

#[test]
fn s4_frequent_profile_draws_more_faults_over_the_same_seed_and_run() {
    assert_eq!(Faults::frequent(), Faults::default().scaled(Faults::FREQUENT_FACTOR));
    assert_eq!(FaultProfile::Default.faults(), Faults::default());
    assert_eq!(FaultProfile::None.faults(), Faults::none());
    for profile in FaultProfile::ALL {
        assert_eq!(profile.to_string().parse::<FaultProfile>(), Ok(profile));
    }
    assert!("often".parse::<FaultProfile>().unwrap_err().contains("frequent"));
    let run = Profile::paper();
    let counts = |faults: &Faults, seed: u64| {
        let r = record(&run, faults, seed);
        let not_offset = r.faults.iter().filter(|f| !matches!(f.kind, FaultKind::Offset { .. })).count();
        let spikes = r.faults.iter().filter(|f| matches!(f.kind, FaultKind::Spike { .. })).count();
        (not_offset, spikes, r.n_telegrams())
    };
    for seed in 1..=3 {
        let (default, _, n) = counts(&Faults::default(), seed);
        let (frequent, spikes, _) = counts(&"frequent".parse::<FaultProfile>().unwrap().faults(), seed);
        assert!(frequent > 5 * default, "seed {seed}: {frequent} faults against {default}");
        // About 1e-2 spikes per telegram on each of the four channels, less the telegrams
        // the bursts hold.
        let rate = spikes as f64 / (4 * n) as f64;
        assert!((0.006..0.012).contains(&rate), "seed {seed}: {rate} spikes per telegram");
    }
}

// --- S5 ------------------------------------------------------------------------------

#[test]
fn s5_roll_turn_is_another_manoeuvre_and_flyable() {
    let standard = Manoeuvre::named("standard").unwrap();
    let roll_turn = Manoeuvre::named("roll-turn").unwrap();
    assert_eq!(standard, Manoeuvre::standard());
    assert_eq!(roll_turn, Manoeuvre::roll_turn());
    assert!(Manoeuvre::named("loop").unwrap_err().contains("roll-turn"));
    assert_eq!((roll_turn.duration, roll_turn.change_at), (standard.duration, standard.change_at));
    // Another schedule: the deflections differ on most samples.
    let settings = s5::Settings::default();
    let samples = (roll_turn.duration / settings.sample_time).round() as usize;
    let differ = (0..samples)
        .filter(|&k| roll_turn.held(k, settings.sample_time) != standard.held(k, settings.sample_time))
        .count();
    assert!(differ > samples / 2, "{differ} of {samples} samples differ");
    // As the standard: every control moves in each half, every switch on the 5 ms grid.
    for half in [0.0, 10.0] {
        for axis in 0..3 {
            assert!(
                (0..2000).any(|k| roll_turn.deflection(half + k as f64 * 0.005)[axis] != 0.0),
                "control {axis} from {half} s"
            );
        }
    }
    for t in roll_turn.switches() {
        assert!((t / 0.005 - (t / 0.005).round()).abs() < 1e-9, "switch at {t} s");
    }
    // A sustained pull: δy held for 6 s in each half.
    for t in [2.5, 5.0, 8.495] {
        assert_eq!(roll_turn.deflection(t)[1], 1.5f64.to_radians());
        assert_eq!(roll_turn.deflection(t + 9.5)[1], -1.5f64.to_radians());
    }
    // Flyable: the plant integrates it with every state finite and in the envelope.
    let truth = simulate_named("roll-turn", &settings).unwrap();
    assert_eq!(truth.time.len(), samples + 1);
    assert!(truth.motion.iter().flatten().chain(truth.measurements.iter().flatten()).all(|v| v.is_finite()));
    for (x, z) in truth.motion.iter().zip(&truth.measurements) {
        let speed = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
        assert!(speed > 300.0 && (5_000.0..20_000.0).contains(&x[6]), "speed {speed} m/s, altitude {} m", x[6]);
        assert!(z[10].abs() < 10f64.to_radians() && z[11].abs() < 10f64.to_radians(), "α {}, β {}", z[10], z[11]);
    }
    // Roll-heavy: the roll rate's RMS at least 1.5 times the standard's.
    let standard_truth = s5::simulate(&settings);
    let rms = |t: &s5::Truth, i: usize| {
        (t.measurements.iter().map(|z| z[i] * z[i]).sum::<f64>() / t.measurements.len() as f64).sqrt()
    };
    assert!(
        rms(&truth, 0) > 1.5 * rms(&standard_truth, 0),
        "roll rate RMS {} against {} rad/s",
        rms(&truth, 0),
        rms(&standard_truth, 0)
    );
    assert_ne!(truth.measurements, standard_truth.measurements);
    // The coefficients change at the same instant.
    let k = (roll_turn.change_at / settings.sample_time).round() as usize;
    assert_ne!(truth.coefficients[k - 1], truth.coefficients[k]);
    assert_eq!(truth.coefficients[k - 1], standard_truth.coefficients[k - 1]);
    // The file round-trips through the reader a caller's own file would use.
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/data/s5_manoeuvre_roll_turn.json")).unwrap();
    assert_eq!(Manoeuvre::from_json(&text), Ok(roll_turn));
}

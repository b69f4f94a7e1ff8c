//! S4's numbers, each with its source: the paper's test run and telegram clock
//! (`[MaglevUKF2024]`, §1.2 and §3.1), the long stator and its position channels, and the
//! high-speed run we add. `[est]` marks our own choice; `docs/studies/s4.md` explains each.

/// Time between two PRW telegrams (s): Δt = 0.02 s. [src: the paper, eq. (2) and §3.1]
pub const TELEGRAM_INTERVAL: f64 = 0.02;

/// The long stator's slot pitch (m): 86 mm, three slots per 258 mm pole pitch. A slot
/// slip shifts a channel's position by one pitch. [est]
pub const SLOT_PITCH: f64 = 0.086;

/// Distance along the train between the head and the tail sensors (m): two end sections
/// of about 25 m with the sensors near their outer ends. The paper does not give it. [est]
pub const HEAD_TO_TAIL: f64 = 50.0;

/// The paper's test run (§3.1): it starts at 0.2 m/s…
pub const PAPER_START_SPEED: f64 = 0.2;
/// …accelerates at 2.5 m/s² up to 5.6 m/s…
pub const PAPER_ACCELERATION: f64 = 2.5;
/// …runs at 5.6 m/s…
pub const PAPER_TOP_SPEED: f64 = 5.6;
/// …and brakes at 2.5 m/s²…
pub const PAPER_DECELERATION: f64 = 2.5;
/// …to a stop at 506.4 m (from where the run starts).
pub const PAPER_STOP_POSITION: f64 = 506.4;
/// The speeds the paper fuses, `t = 1, 2, …, 5695` in its eq. (19): one per pair of
/// neighbouring telegrams, so the recording holds 5,696 telegrams and lasts
/// 5,695 × 0.02 s = 113.9 s. The motion takes 92.59 s; the rest the vehicle stands at
/// the stop (our reading, `docs/studies/s4.md`).
pub const PAPER_SPEED_SAMPLES: usize = 5695;

/// The high-speed run's top speed (m/s): 500 km/h, the top of the ETCS speed-accuracy
/// band and the Transrapid's speed under test conditions. [src: `[SUBSET-041]`]
pub const HIGH_SPEED_TOP_SPEED: f64 = 500.0 / 3.6;
/// Its acceleration limit (m/s²): the Shanghai Transrapid reaches 350 km/h in about
/// 2 min, 0.81 m/s² on average. [src: operator figures quoted for the Shanghai line]
pub const HIGH_SPEED_ACCELERATION: f64 = 0.8;
/// Its service deceleration (m/s²): the same linear motor brakes it. [est]
pub const HIGH_SPEED_DECELERATION: f64 = 0.8;
/// Its jerk limit (m/s³): a comfortable ride, half of the ~1 m/s³ commonly held as the
/// limit of longitudinal comfort in rail vehicles (reviewed by Powell & Palacín, Urban
/// Rail Transit 1(2), 2015). [est]
pub const HIGH_SPEED_JERK: f64 = 0.5;
/// How long it cruises at the top speed (s). [est]
pub const HIGH_SPEED_CRUISE: f64 = 60.0;

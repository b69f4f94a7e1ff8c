//! Study S3's truth: a whole rail car on two rails, richer than the 17-DOF estimator that
//! is tried on it ([`plant`]). The car body, two bogies and four wheelsets bounce, pitch
//! (not the wheelsets), roll, move sideways and yaw ([`vehicle`], 31 degrees of freedom);
//! left and right primary and secondary springs at their spans and heights; each wheel
//! touches its rail through a conical tread, Hertz normal force and linear Kalker creep
//! ([`contact`]); each rail is S2's rail on its own sleepers and ballast. The data are in
//! one place ([`parameters`]), the rails' irregularities in [`irregularity`], the cases and
//! the measurements, sampled as S2's data acquisition does, in [`cases`].
//!
//! **In:** wheelset lateral displacement and yaw, bogie and car-body lateral, roll and yaw;
//! equivalent-conicity rolling-radius difference and the contact point's shift across the
//! wheel (the vertical forces' levers change with the lateral displacement); the normal
//! forces' lateral components (the gravitational stiffness); linear creep with the contact
//! patch's growth with load; the lateral forces at rail height, which load one wheel and
//! unload the other; the centres of mass at their heights (pendulum stiffness in roll and
//! pitch); loss of contact per wheel; independent left and right vertical irregularities
//! (a profile and a cross-level), an alignment, a dipped joint on one rail, a twist.
//!
//! **Left out:** the wheelsets' spin and pitch (they roll at `V/r0`), every longitudinal
//! freedom, spin creep and creep saturation, flange contact, the rails' lateral, roll and
//! longitudinal motion (the rails are rigid sideways), gauge irregularity, shared sleepers
//! (each rail has its own), curves and cant, the bump stops and the anti-roll bar.

pub mod cases;
pub mod contact;
pub mod irregularity;
pub mod parameters;
pub mod plant;
pub mod vehicle;

//! Issue 25: the field frozen at an orbit instant (docs/margins.md, "Magnetorquer loops"),
//! checked against the unfrozen model on paper 003's 617 km, 97.8° orbit with the dipole
//! field: frozen in LVLH, the field keeps its LVLH components (to round-off) while the
//! orbit goes on, and equals the model at the instant it was frozen; frozen in the
//! reference frame it is the instant's ECI vector for ever. The unfrozen model moves by
//! tens of percent over the same third of an orbit (so the check could fail).

use sim_core::environment::frames::rot_lvlh_to_eci;
use sim_core::environment::model::{EnvSnapshot, FrozenField};
use sim_core::scenario::Scenario;

fn lvlh_components(s: &EnvSnapshot) -> nalgebra::Vector3<f64> {
    let (r, v) = s.orbit.unwrap();
    rot_lvlh_to_eci(&r, &v).transpose() * s.b_ref_t.unwrap()
}

#[test]
fn field_frozen_in_lvlh_keeps_its_lvlh_components_and_in_eci_its_vector() {
    let sc = Scenario::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/paper003/orbit-mtq-hold.toml"
    )))
    .unwrap();
    let (t0, t1) = (1000.0, 1000.0 + 5822.4 / 3.0);
    let mut model = sc.environment().unwrap().unwrap();
    let (m0, m1) = (model.snapshot(t0).unwrap(), model.snapshot(t1).unwrap());
    let moved = (lvlh_components(&m1) - lvlh_components(&m0)).norm() / lvlh_components(&m0).norm();
    assert!(moved > 0.1, "the unfrozen field must move in LVLH over a third of an orbit: {moved}");

    let mut lvlh = sc.environment().unwrap().unwrap();
    let frozen = lvlh.freeze_field(&m0, true).unwrap();
    assert!(matches!(frozen, FrozenField::Lvlh(_)));
    let (f0, f1) = (lvlh.snapshot(t0).unwrap(), lvlh.snapshot(t1).unwrap());
    let b0 = m0.b_ref_t.unwrap();
    assert!((f0.b_ref_t.unwrap() - b0).norm() <= 1e-12 * b0.norm(), "{f0:?} vs {m0:?}");
    let drift = (lvlh_components(&f1) - lvlh_components(&m0)).norm() / b0.norm();
    assert!(drift <= 1e-12, "frozen in LVLH: {drift}");
    assert_eq!(f1.orbit, m1.orbit, "the orbit goes on");
    eprintln!("unfrozen field moved {:.1} % in LVLH, frozen {drift:.1e}", 100.0 * moved);

    let mut eci = sc.environment().unwrap().unwrap();
    assert!(matches!(eci.freeze_field(&m0, false), Some(FrozenField::Reference(_))));
    assert_eq!(eci.snapshot(t1).unwrap().b_ref_t, Some(b0));
}

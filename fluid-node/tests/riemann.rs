//! The `riemann` method's own checks (its validation rows run with every solver's in
//! `solvers.rs`, its same bits on thread ranks in `threads.rs`).

use fluid_node::validation::{scene_errors, still_water_scene};

/// `[fluid.riemann]` takes WCSPH's parameters but not the artificial viscosity and δ-SPH
/// whose work its Riemann solver does: those are refused by name, with the fix; its own
/// `wall_limiter` (the walls' dissipation) is not WCSPH's.
#[test]
fn riemann_parameters_are_checked() {
    let scene = still_water_scene("riemann", 0.1, 0.025, 0.1, None);
    let text = toml::to_string(&scene).unwrap();
    let checked = |extra: &str| scene_errors(&format!("{text}\n[fluid.riemann]\n{extra}\n"));
    assert_eq!(
        checked(
            "sound_speed = 20.0\ngamma = 7.0\nsmoothing_ratio = 1.3\ncfl = 0.2\nskin = 0.1\nintegrator = \"symplectic\"\nwall_limiter = 10.0"
        ),
        ""
    );
    for (bad, field) in [
        ("alpha = 0.01", "alpha"),
        ("delta = 0.1", "delta"),
        ("sound_speed = -1.0", "sound_speed"),
        ("skin = 2.0", "skin"),
        ("wall_limiter = -1.0", "wall_limiter"),
    ] {
        let e = checked(bad);
        assert!(
            e.contains(&format!("fluid.riemann.{field}")) && e.contains("fix"),
            "{bad}: {e}"
        );
    }
    let e = checked("flux = \"riemann\"");
    assert!(e.contains("fluid.riemann") && e.contains("flux"), "{e}");
    // The walls' dissipation is the Riemann solver's: `wcsph` refuses it by name.
    let scene = still_water_scene("wcsph", 0.1, 0.025, 0.1, None);
    let text = toml::to_string(&scene).unwrap();
    let e = scene_errors(&format!("{text}\n[fluid.wcsph]\nwall_limiter = 10.0\n"));
    assert!(
        e.contains("fluid.wcsph.wall_limiter") && e.contains("fix"),
        "{e}"
    );
}

/// The impact study's rows (`fluid-validate --only impact-study-riemann` runs H/dx = 15, 30,
/// 60), here at H/dx = 6 and 8: per resolution a peak and an impulse row for each reading of
/// sensor 1 (the water's pressure, the wall's load), then one row per reading on the peak's
/// growth whose verdict is its own ratio against the tolerance.
#[test]
fn the_impact_study_tables_each_resolution_and_the_peaks_growth() {
    use fluid_node::validation::{PEAK_GROWTH_TOLERANCE, validate_impact_study};
    let rows = validate_impact_study("riemann", &[6, 8], |_| {});
    assert_eq!(rows.len(), 10, "{rows:#?}");
    for (at, quantity) in [(0, "peak pressure"), (1, "peak wall load")] {
        let peak = |k: usize| -> f64 {
            let r = &rows[4 * k + at];
            assert_eq!(r.quantity, quantity, "{r:?}");
            r.measured.trim_end_matches(" mbar").parse().unwrap()
        };
        let (coarse, fine) = (peak(0), peak(1));
        assert!(
            coarse > 10.0 && fine > 10.0,
            "{quantity}: {coarse} and {fine} mbar"
        );
        let impulse = &rows[2 + at];
        assert!(
            impulse.quantity.starts_with("impulse of the"),
            "{impulse:?}"
        );
        let growth = &rows[8 + at];
        assert!(growth.quantity.starts_with(quantity), "{growth:?}");
        assert_eq!(growth.measured, format!("{coarse:.1} → {fine:.1}"));
        assert_eq!(
            growth.pass,
            fine / coarse <= 1.0 + PEAK_GROWTH_TOLERANCE,
            "{growth:?}"
        );
    }
}

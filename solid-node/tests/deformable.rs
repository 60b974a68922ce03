//! Deformable (12-DOF) blocks through the solver interface: unknowns, geometry out, strain
//! loads in, outputs, and "model no more than a scene needs" (rigid scenes pay nothing).

use shared::geometry::strain::{self, Strain};
use shared::math::{Matrix, Point, Real, Vector};
use shared::protocol::{BlockLoad, BlockState};
use shared::solver::{SolidSolver, Solver};
use solid_node::integrators::explicit::ExplicitParams;
use solid_node::verification::{EXPLICIT, Harness, block_toml, box_corners, scene};

const ELASTIC: &str = "elastic = { young_modulus = 5e6, poisson_ratio = 0.25 }";

/// A floor, a rigid box and (optionally) a deformable one, in space or under gravity, 1 m above
/// the floor.
fn two_blocks(deformable: bool, gravity: Real, contact: &str) -> shared::scene::Scene {
    blocks_at(deformable, gravity, contact, 1.0)
}

fn blocks_at(deformable: bool, gravity: Real, contact: &str, z: Real) -> shared::scene::Scene {
    scene(
        "two",
        [0.0, 0.0, -gravity],
        10.0,
        "[solid.implicit]\ndisplacement_limit = 10.0",
        contact,
        &[
            block_toml(
                "floor",
                "fixed",
                2500.0,
                &box_corners([-3.0, -3.0, -0.5], [3.0, 3.0, 0.0]),
                "",
            ),
            block_toml(
                "rigid",
                "free",
                2500.0,
                &box_corners([-2.0, -0.2, z], [-1.6, 0.2, z + 0.4]),
                "",
            ),
            block_toml(
                "soft",
                "free",
                2000.0,
                &box_corners([1.0, -0.25, z], [1.5, 0.25, z + 0.5]),
                if deformable { ELASTIC } else { "" },
            ),
        ],
    )
}

#[test]
fn unknowns_are_six_per_rigid_and_twelve_per_deformable_block() {
    for solver in solid_node::REGISTRY.names() {
        let h = Harness::new(&two_blocks(false, 9.81, ""), solver).unwrap();
        assert_eq!(h.solver.unknowns(), 12, "{solver}: two rigid free blocks");
        assert!(h.world().deformable.is_empty());
        let h = Harness::new(&two_blocks(true, 9.81, ""), solver).unwrap();
        assert_eq!(h.solver.unknowns(), 18, "{solver}: rigid + deformable");
        let soft = h.solver.block_index("soft").unwrap();
        assert_eq!(h.world().deformable, vec![soft]);
        assert_eq!(h.block("floor").unknowns(), 0);
    }
}

/// In space, a rigid cube's explicit proposal is safety·2/ω of the resting floor estimate
/// alone (6k/m for a cube on four corner springs, shear springs off): no elastic mode. The
/// same cube made deformable proposes a shorter step, bounded by its elastic mode.
#[test]
fn rigid_explicit_proposal_has_no_elastic_mode() {
    let cube = |extra: &str| {
        scene(
            "cube",
            [0.0, 0.0, 0.0],
            5.0,
            "",
            "normal_stiffness = 1e6\nshear_ratio = 0.0",
            &[block_toml(
                "cube",
                "free",
                2000.0,
                &box_corners([-0.25; 3], [0.25; 3]),
                extra,
            )],
        )
    };
    let s = cube("");
    let h = Harness::new(&s, "explicit").unwrap();
    let m = h.block("cube").mass;
    let expect = safety_factor(&s) * 2.0 / (6.0 * 1e6 / m).sqrt();
    let rigid = h.solver.dt_proposal();
    assert!((rigid / expect - 1.0).abs() < 1e-9, "{rigid} vs {expect}");

    // E = 5e8: ω_elastic = sqrt(36 K/ρ)/L = 4899 rad/s, above sqrt(6k/m) = 155 rad/s.
    let s = cube("elastic = { young_modulus = 5e8, poisson_ratio = 0.25 }");
    let h = Harness::new(&s, "explicit").unwrap();
    let w_el = solid_node::blocks::elastic::cube_frequencies(5e8, 0.25, 2000.0, 0.5).0;
    let soft = h.solver.dt_proposal();
    assert!(soft < rigid, "{soft} vs {rigid}");
    assert!(soft * w_el <= 2.0 * safety_factor(&s) + 1e-12);
    assert!(
        soft * w_el > 0.9 * 2.0 * safety_factor(&s),
        "{}",
        soft * w_el
    );
}

/// The geometry message of a deformable block: its flag, strain and strain rate, the deformed
/// corners c + R (I + E) X, and a point velocity (shared's, from the message) that agrees with
/// the solver's own; the face planes follow the deformed corners.
#[test]
fn geometry_message_carries_the_strain() {
    let s = two_blocks(true, 0.0, "");
    let mut h = Harness::new(&s, "explicit").unwrap();
    let soft = h.solver.block_index("soft").unwrap();
    let e0 = Strain::new(2e-3, -1e-3, 5e-4, 1e-3, -2e-3, 3e-3);
    let rate = Strain::new(0.1, 0.0, -0.2, 0.05, 0.0, 0.3);
    h.solver.set_initial_strain(soft, e0, rate).unwrap();
    h.solver.read_loads(&[BlockLoad::default(); 2]);
    h.solver.advance(1e-4).unwrap();

    let n = h.solver.vertex_count();
    let mut states = vec![BlockState::default(); 2];
    let mut verts = vec![[0.0; 3]; n];
    h.solver.write_geometry(&mut states, &mut verts);
    assert!(!states[0].is_deformable());
    assert_eq!(states[0].strain, [0.0; 6]);
    let st = &states[1];
    let b = h.block("soft");
    let el = b.elastic.as_ref().unwrap();
    assert!(st.is_deformable());
    assert_eq!(st.strain, <[f64; 6]>::from(el.strain));
    assert_eq!(st.strain_rate, <[f64; 6]>::from(el.rate));
    assert!((el.strain - e0).norm() > 0.0, "the strain moved");
    let f = st.deformation();
    for (k, x) in b.shape.vertices.iter().enumerate() {
        let v = verts[st.first_vertex as usize + k];
        let expect = st.centroid() + f * x.coords;
        assert!((Point::from(v) - expect).norm() < 1e-14);
        // Every deformed corner lies on the deformed planes of its faces, inside the others.
        for &fi in &b.vertex_faces[k] {
            let fi = fi as usize;
            let d = b.world_normals[fi].dot(&expect.coords) - b.world_offsets[fi];
            assert!(d.abs() < 1e-14, "corner {k} off face {fi} by {d:e}");
        }
        assert!(b.plane_distance(&expect).0 < 1e-14);
        let pv = st.point_velocity(&expect);
        assert!((pv - b.point_velocity(&expect)).norm() < 1e-14);
    }
    // R Ė X at a corner: the strain rate moves the corners.
    let x = b.shape.vertices[0].coords;
    let rigid = b.velocity
        + b.angular_velocity
            .cross(&(b.world_vertices[0] - b.position));
    let strain_part = b.rotation * (strain::tensor(&el.rate) * x);
    assert!((b.point_velocity(&b.world_vertices[0]) - rigid - strain_part).norm() < 1e-14);
    // And the step displacement of a material point includes the strain change.
    let before = b.prev_position
        + b.prev_rotation * ((Matrix::identity() + strain::tensor(&el.prev_strain)) * x);
    let step = b.point_step_displacement(&b.world_vertices[0]);
    assert!((step - (b.world_vertices[0] - before)).norm() < 1e-15);
    assert!(step.norm() > 0.0);
}

/// A constant generalised fluid load g on the strains of a block in space (along the cube's
/// volumetric mode): the step response peaks at 2 e* (central difference, undamped) and
/// settles at e* = (V D)⁻¹ g (Shi's Newmark damps the oscillation out); rigid blocks ignore a
/// strain load.
#[test]
fn strain_load_from_the_fluid_strains_the_block() {
    let g = Strain::new(300.0, 300.0, 300.0, 0.0, 0.0, 0.0);
    for solver in solid_node::REGISTRY.names() {
        let s = two_blocks(true, 0.0, "");
        let mut h = Harness::new(&s, solver).unwrap();
        let soft = h.solver.block_index("soft").unwrap();
        let el = h.world().blocks[soft].elastic.clone().unwrap();
        let target = el.stiffness.try_inverse().unwrap() * g;
        let load = BlockLoad {
            strain_load: g.into(),
            ..Default::default()
        };
        let mut peak: Real = 0.0;
        let omega_dt = if solver == EXPLICIT { 0.05 } else { 1.0 };
        let dt = omega_dt / el.omega2.sqrt();
        for _ in 0..1000 {
            h.solver.read_loads(&[load, load]);
            h.solver.advance(dt).unwrap();
            peak = peak.max(h.block("soft").strain()[0]);
        }
        let e = h.block("soft").strain();
        if solver == EXPLICIT {
            assert!(
                (peak / (2.0 * target[0]) - 1.0).abs() < 0.01,
                "{peak} vs 2·{}",
                target[0]
            );
        } else {
            assert!(
                (e - target).norm() < 1e-3 * target.norm(),
                "{e} vs {target}"
            );
        }
        assert_eq!(h.block("rigid").strain(), Strain::zeros());
        assert_eq!(h.block("rigid").position, h.world().blocks[1].origin);
        // No force on the centroid: the block does not move.
        assert!(h.block("soft").velocity.norm() < 1e-12, "{solver}");
        assert!(h.block("soft").angular_velocity.norm() < 1e-12, "{solver}");
    }
}

/// A free-falling deformable block keeps zero strain (uniform gravity loads no strain), and a
/// spinning one neither grows nor strains (the rotation is carried exactly, co-rotationally).
#[test]
fn gravity_and_spin_do_not_strain() {
    for solver in solid_node::REGISTRY.names() {
        let s = scene(
            "spin",
            [0.0, 0.0, -9.81],
            20.0,
            "[solid.implicit]\ndisplacement_limit = 10.0",
            "",
            &[block_toml(
                "soft",
                "free",
                2000.0,
                &box_corners([-0.3, -0.2, -0.1], [0.3, 0.2, 0.1]),
                &format!("{ELASTIC}\nangular_velocity = [3.0, 0.0, 9.5]"),
            )],
        );
        let mut h = Harness::new(&s, solver).unwrap();
        h.run_until(1.0, Some(1e-3), |_| {}).unwrap();
        let b = h.block("soft");
        assert!(b.strain().norm() < 1e-12, "{solver}: {}", b.strain());
        for (v, x) in b.world_vertices.iter().zip(&b.shape.vertices) {
            assert!(((v - b.position).norm() / x.coords.norm() - 1.0).abs() < 1e-12);
        }
        assert!(
            (b.position.z - b.origin.z + 0.5 * 9.81).abs() < 1e-9,
            "{solver}"
        );
    }
}

#[test]
fn csv_and_vtk_carry_strain_and_stress_of_deformable_blocks() {
    let mut s = two_blocks(true, 9.81, "damping_ratio = 0.2");
    s.output.vtk = true;
    let mut h = Harness::new(&s, "implicit").unwrap();
    h.run_until(0.05, None, |_| {}).unwrap();
    h.solver.write_frame(1, h.time()).unwrap();
    h.solver.finish().unwrap();
    let csv = std::fs::read_to_string(h.run_dir().join("blocks.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header.len(), 15 + 12);
    assert_eq!(&header[15..18], &["exx", "eyy", "ezz"]);
    assert_eq!(header[26], "sxy");
    for l in lines {
        let cols: Vec<&str> = l.split(',').collect();
        assert_eq!(cols.len(), 27, "{l}");
        if cols[1] == "rigid" {
            assert!(cols[15..].iter().all(|c| c.parse::<f64>().unwrap() == 0.0));
        }
    }
    let vtp =
        String::from_utf8_lossy(&std::fs::read(h.run_dir().join("blocks_00001.vtp")).unwrap())
            .into_owned();
    for name in [
        "von_mises_stress",
        "volumetric_strain",
        "strain_xy",
        "stress_zz",
    ] {
        assert!(vtp.contains(name), "{name} missing");
    }
}

/// Contact on a deformable block: the floor's reaction loads its strains with T_eᵀ Rᵀ f,
/// compressing it (the full check against ρgH/(2E) is the verification case); dropped from
/// 1 m it lands and rebounds (the impact rings the strain modes) without the open–close
/// iterations stalling on its corners, which sit on the friction limit as they spread.
#[test]
fn contact_compresses_a_deformable_block() {
    let s = two_blocks(true, 9.81, "damping_ratio = 0.3");
    let mut h = Harness::new(&s, "implicit").unwrap();
    h.run_until(1.2, None, |_| {}).unwrap();
    let s = blocks_at(true, 9.81, "damping_ratio = 0.3", 0.0);
    let mut h = Harness::new(&s, "implicit").unwrap();
    h.run_until(0.5, None, |_| {}).unwrap();
    let soft = h.solver.block_index("soft").unwrap();
    let w = h.world();
    assert!(
        w.blocks[soft].aabb_min.z < 1e-3,
        "landed? {:?}",
        w.blocks[soft].aabb_min
    );
    assert!(
        w.blocks[soft].strain()[2] < -5e-4,
        "{}",
        w.blocks[soft].strain()
    );
    assert!(w.contact_strain[soft][2] < 0.0);
    let rigid = h.solver.block_index("rigid").unwrap();
    assert_eq!(w.contact_strain[rigid], Strain::zeros());
    let _ = Vector::zeros();
}

/// `[solid.explicit] safety_factor` of a scene, as the explicit scheme reads it.
fn safety_factor(s: &shared::scene::Scene) -> Real {
    shared::registry::params::<ExplicitParams>(&s.solid.solvers, "solid", EXPLICIT)
        .unwrap()
        .safety_factor
}

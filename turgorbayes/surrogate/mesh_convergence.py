"""Measured discretization error of the FE settings of the surrogate tables (their metadata).

A record of the surrogate package, not of :mod:`turgorbayes.fem`: a table's points are
fingerprinted by the hash of the FE sources, which updating this record must not change.
The measured points of ``surrogate_mesh``, ``table_mesh`` and ``tip_tables_mesh`` are written by
``scripts/fill_mesh_convergence.py`` from the result files of ``studies/fem_convergence.py``,
``studies/fem_domain_corners.py`` and ``studies/fem_tip_radius.py`` into
:mod:`turgorbayes.surrogate._mesh_points` (a test checks they agree); the settings, DOF counts and
error estimates below are written by hand (the dates say when), as are the production mesh's
``points`` and ``thickness_tables_mesh``, whose runs' output was not committed.
``rel_diff`` is (refined - production) / production of k/(P R_c) at h = R_c/20 and of the
linear stiffness. ``half_size``: mesh_scale 0.5 (half the in-plane element size);
``two_layers``: two elements through the wall; ``penalty_x4``: contact penalty x 4.
"""

from turgorbayes.surrogate._mesh_points import MEASURED

__all__ = ["MESH_CONVERGENCE"]

MESH_CONVERGENCE = {
    "date": "2026-11-22",
    "benchmark": "studies/fem_convergence.py",
    "production": {"mesh_scale": 1.0, "n_thick": 1, "dofs": 40905},
    "points": [
        {"x": 0.05, "ratio": 1.0, "variant": "half_size", "dofs": 104013,
         "rel_diff_k": 4e-4, "rel_diff_k_linear": -6e-4},
        # coarser alternatives (not used): growth 0.5 (26739 DOFs) and mesh_scale 1.5
        {"x": 0.05, "ratio": 1.0, "variant": "growth_0.5", "dofs": 26739,
         "rel_diff_k": 1.3e-3, "rel_diff_k_linear": -5.8e-3},
        {"x": 0.05, "ratio": 1.0, "variant": "coarse_1.5", "dofs": 24759,
         "rel_diff_k": 4.4e-3, "rel_diff_k_linear": -1.41e-2},
        # through-thickness resolution dominates, above all for the linear stiffness
        {"x": 0.05, "ratio": 1.0, "variant": "two_layers", "dofs": 68175,
         "rel_diff_k": -2.1e-3, "rel_diff_k_linear": -4.08e-2},
        # penalty x 4 without Uzawa updates (now the penetration is removed to 0.1% of h)
        {"x": 0.05, "ratio": 1.0, "variant": "penalty_x4", "dofs": 40905,
         "rel_diff_k": 1.3e-3, "rel_diff_k_linear": -8e-4},
    ],
    # not yet measured: the sweep's ends x = 0.01 and 0.5 (each refined run took ~20 min
    # on the shared machine)
    "estimate_rel_error_k": 3e-3,
    "estimate_rel_error_k_linear": 4e-2,
    # the mesh of the shipped surrogate since 2026-11-23: mesh_scale 3 with the tip element
    # size held at 3 nm (h_min 1e-9), 20205 DOFs. "half": every size halved (mesh_scale 1.5,
    # h_min 1e-9: 1.5 nm at the tip, 33939 DOFs); "best": the finest mesh run (3 nm at the
    # tip halved to 1.5 nm, 6 nm substrate line, 60 nm far field; 64215 DOFs).
    # studies/fem_convergence.py, 2026-11-22 (variants scale_3_tip, scale_1.5_tip,
    # tip_mesh_half; studies/results/fem_convergence_tip_mesh.txt), ratio 1
    "surrogate_mesh": {
        "mesh_scale": 3.0, "h_min": 1e-9, "dofs": 20205,
        "refined": {"mesh_scale": 1.5, "h_min": 1e-9, "dofs": 33939},
        "best": {"mesh_scale": 1.5, "h_min": 1e-9, "h_max": 4e-8, "h_bottom": 4e-9, "dofs": 64215},
        "points": MEASURED["surrogate_mesh"],
        # k/PR within 0.8 % of the best mesh at both ends of the table and at the
        # physiological point; against half the element size within 0.33 % at x = 0.01, 0.0706
        # and 0.52 (the specified sweep) and -1.10 % at the table's extra low end x = 0.005; the
        # linear stiffness is not converged at small x (first contact at 1 nm depth spans one
        # or two elements) and the inference does not use it
        "estimate_rel_error_k": 8e-3,
    },
    # the mesh of the table settings since 2026-11-26 (turgorbayes.fem.TABLE_SETTINGS, called
    # tip_mesh in studies/results/fem_convergence_tip_mesh.txt): mesh_scale 3 with 3 nm at
    # the tip, 12 nm along the substrate, 120 nm far away, 29493 DOFs; "half": every size
    # halved (64215 DOFs). x = 0.005 / 0.0706 / 0.52 (ratio 1, 6 depth steps): 2026-11-22;
    # x = 0.001 and the extended domain's other corners (table depth steps):
    # studies/results/fem_domain_corners*.txt, 2026-11-26
    "table_mesh": {
        "mesh_scale": 3.0, "h_min": 1e-9, "h_bottom": 4e-9, "h_max": 4e-8, "dofs": 29493,
        "refined": {"mesh_scale": 1.5, "h_min": 1e-9, "h_bottom": 4e-9, "h_max": 4e-8,
                    "dofs": 64215},
        "points": MEASURED["table_mesh"],
        # the 2026-11-23 table's mesh (surrogate_mesh below) against its half-size version at
        # x = 0.001: +1.45 % (ratio 1) and +1.49 % (ratio 0.15) too stiff; this mesh: 0.56 %
        "estimate_rel_error_k": 6e-3,
    },
    # the mesh of the surrogate shipped until 2026-11-22 (mesh_scale 3, 9 nm under the tip,
    # 13167 DOFs; today the thickness tables and their 6 nm reference k_over_PR_t6nm_mesh3.nc)
    # against half its element size (mesh_scale 1.5, 24759 DOFs, itself not tip-resolved)
    "thickness_tables_mesh": {
        "mesh_scale": 3.0, "dofs": 13167, "refined": {"mesh_scale": 1.5, "dofs": 24759},
        "points": [
            {"x": 0.005, "ratio": 1.0, "rel_diff_k": 3.7e-3, "rel_diff_k_linear": 2.0e-3},
            {"x": 0.005, "ratio": 0.25, "rel_diff_k": 4.4e-3, "rel_diff_k_linear": -2.96e-2},
            {"x": 0.0706, "ratio": 1.0, "rel_diff_k": 1.13e-2, "rel_diff_k_linear": -6e-4},
            {"x": 0.0706, "ratio": 0.25, "rel_diff_k": 1.33e-2, "rel_diff_k_linear": -1.05e-2},
            {"x": 0.1507, "ratio": 1.0, "rel_diff_k": 1.68e-2, "rel_diff_k_linear": -7e-4},
            {"x": 0.2799, "ratio": 1.0, "rel_diff_k": 7.81e-2, "rel_diff_k_linear": -1.0e-3},
            {"x": 0.52, "ratio": 1.0, "rel_diff_k": 1.166e-1, "rel_diff_k_linear": -1.3e-3},
            {"x": 0.52, "ratio": 0.25, "rel_diff_k": 1.187e-1, "rel_diff_k_linear": -2.97e-2},
        ],
    },
    # the tip-radius tables' mesh (k_over_PR_tip*nm.nc, 2026-11-27): the 2026-11-23 mesh with
    # 1.5 nm under the tip (h_min 0.5e-9), 24633 DOFs, against the same with 0.75 nm under the
    # tip (30627 DOFs), at the physiological point x = 0.0706, ratio 0.457, for the sharpest
    # and the bluntest tip; with 3 nm under the tip the 3 nm tip was 2.07 % too soft
    # (studies/fem_tip_radius.py, studies/results/fem_tip_radius.txt)
    "tip_tables_mesh": {
        "mesh_scale": 3.0, "h_min": 0.5e-9, "dofs": 24633,
        "refined": {"mesh_scale": 3.0, "h_min": 0.25e-9, "dofs": 30627},
        "points": MEASURED["tip_tables_mesh"],
    },
}

"""Classical shell benchmarks and the work-consistency of loads and reactions.

* Scordelis–Lo roof (MacNeal & Harder 1985): vertical displacement at mid-length of the free
  edge, converged Kirchhoff–Love value 0.3006, within 0.5 %.
* Pinched cylinder with rigid diaphragms (Flügge; MacNeal & Harder): radial displacement
  under the unit load 1.8248e-5, within 0.8 % (16 × 16), on a one-eighth model with symmetry supports and
  on full periodic cylinders; all agree.
* Loads are work-consistent (MODEL.md §3): the analytic total of every applied load equals the
  resultant of the support reactions, R · I_h(e_k), up to a discretisation error that
  decreases under refinement.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp

import shellcontact as sc
from shellcontact.analysis.discretization import case_mesh
from shellcontact.errors import InputError
from shellcontact.linalg import factorize
from shellcontact.outputs.results import ShellSolution
from shellcontact.shell import model
from shellcontact.shell.geometry import Shell, rigid_motion
from shellcontact.shell.loads import LineLoad, Loads, PointLoad, load_vector
from shellcontact.shell.material import Isotropic
from shellcontact.shell.mesh import structured
from shellcontact.shell.spaces import ShellSpace
from shellcontact.shell.supports import Reduction, Supports, check_rigid_motions, constrained_dofs, periodic_pairs

SCORDELIS_LO = 0.3006
PINCHED = 1.8248e-5


def _with_mesh(case: sc.Case, **kw) -> sc.Case:
    return replace(case, mesh=replace(case.mesh, **kw))


# ---------------------------------------------------------------------------------------------
# Scordelis–Lo roof
# ---------------------------------------------------------------------------------------------
def test_scordelis_lo_roof(examples_dir):
    case = sc.load_case(examples_dir / "scordelis_lo.toml")
    print("\nScordelis-Lo roof (quarter model), vertical displacement at mid-length of the free edge")
    print("  mesh     dofs      u_z        rel. error   time [s]")
    errors = []
    for n in (case.mesh.nx // 2, case.mesh.nx, 2 * case.mesh.nx):  # the example's mesh halved and doubled
        t0 = time.perf_counter()
        res = sc.solve(_with_mesh(case, nx=n, nphi=n))
        uz = res.summary()["probes"][0]["displacement"][2]
        err = (-uz - SCORDELIS_LO) / SCORDELIS_LO
        errors.append(err)
        print(f"{n:3d}x{n:<3d} {res.solution.space.ndofs:7d} {uz:12.6f} {err:12.2e} {time.perf_counter() - t0:8.2f}")
    assert abs(errors[1]) < 5e-3  # the example's own mesh
    assert abs(errors[2]) < 5e-3
    assert abs(errors[2]) < abs(errors[1]) < abs(errors[0])


# ---------------------------------------------------------------------------------------------
# pinched cylinder
# ---------------------------------------------------------------------------------------------
def _pinned_periodic_reduction(space: ShellSpace, supports: Supports, pin: int) -> sp.csr_matrix:
    """U = P U_r for periodic φ-edges, the edge supports and one extra fixed dof ``pin``.

    The same construction as supports.Reduction.build, plus the pin: with rigid diaphragms at
    both ends the axial translation is a zero-energy mode that one fixed axial dof removes.
    """
    n = space.ndofs
    master, sign = np.arange(n), np.ones(n)
    slave, mst, sg = periodic_pairs(space)
    master[slave], sign[slave] = mst, sg
    fixed = np.zeros(n, dtype=bool)
    fixed[constrained_dofs(space, supports)] = True
    fixed[pin] = True
    fixed |= fixed[master]
    check_rigid_motions(space, np.nonzero(fixed)[0])  # now no rigid motion is left
    free = np.nonzero((master == np.arange(n)) & ~fixed)[0]
    col = np.full(n, -1)
    col[free] = np.arange(free.size)
    rows = np.nonzero(~fixed)[0]
    return sp.csr_matrix((sign[~fixed], (rows, col[master[~fixed]])), shape=(n, free.size))


def test_pinched_cylinder_eighth_model_convergence(examples_dir):
    case = sc.load_case(examples_dir / "pinched_cylinder_eighth.toml")
    print("\npinched cylinder, 1/8 model, graded mesh (ratio", case.mesh.grading_ratio, ")")
    print("  mesh     dofs       w under load    rel. error   time [s]")
    errs = []
    for n in (8, 12, case.mesh.nx, 24):
        t0 = time.perf_counter()
        res = sc.solve(_with_mesh(case, nx=n, nphi=n))
        w = res.summary()["probes"][0]["w"]
        errs.append((-w - PINCHED) / PINCHED)
        print(
            f"{n:3d}x{n:<3d} {res.solution.space.ndofs:7d} {w:16.6e} {errs[-1]:12.2e} {time.perf_counter() - t0:8.2f}"
        )
    # measured −3.47e-2, −7.35e-3, −1.55e-3 (the example's 16 × 16), +7.2e-4 (24 × 24)
    assert abs(errs[2]) < 8e-3  # the example's mesh
    assert abs(errs[3]) < 5e-3
    # the reactions balance the applied P/4 (work-consistent point load)
    R = sc.solve(case).solution.reaction_resultant()
    assert np.allclose(R, [0.0, 0.25, 0.0], atol=1e-4 * 0.25)


def test_pinched_cylinder_full_and_eighth_agree(examples_dir):
    """One-eighth model, full periodic half-length cylinder and full periodic full-length cylinder.

    The three meshes are mirror images of each other (graded node lines symmetric about the
    symmetry planes, 'alternate' diagonals), and the symmetric subspace of the full P2 × P2 ×
    Argyris space is exactly the space with the symmetry supports (v = 0, w_s = w_xs = 0 and the
    edge-normal dofs on a φ-plane), so the three discrete solutions coincide up to round-off.
    """
    eighth = sc.load_case(examples_dir / "pinched_cylinder_eighth.toml")
    full = sc.load_case(examples_dir / "pinched_cylinder_full.toml")
    assert full.shell.full and full.supports.periodic
    t0 = time.perf_counter()
    r8 = sc.solve(eighth)
    t8 = time.perf_counter() - t0
    t0 = time.perf_counter()
    rf = sc.solve(full)
    tf = time.perf_counter() - t0
    w8 = r8.summary()["probes"][0]["w"]
    wf = [p["w"] for p in rf.summary()["probes"]]

    # full length [-300, 300], diaphragms at both ends: rejected as it stands (axial translation) ...
    long_case = replace(
        full,
        shell=replace(full.shell, length=600.0, x_start=-300.0),
        supports=Supports("simply_supported", "simply_supported", "periodic", "periodic"),
        mesh=replace(full.mesh, nx=2 * full.mesh.nx),
    )
    with pytest.raises(InputError, match="translation along x"):
        sc.solve(long_case)
    # ... and solved with one axial dof pinned (the loads have no axial resultant), full loads P
    t0 = time.perf_counter()
    mesh = case_mesh(long_case)
    space = ShellSpace(mesh)
    A = model.stiffness(space)
    loads = Loads(points=(PointLoad(0.0, 0.0, (0.0, -1.0, 0.0)), PointLoad(0.0, math.pi, (0.0, 1.0, 0.0))))
    F = load_vector(space, loads)
    far = int(np.argmin(np.hypot(mesh.p[0] - 300.0, mesh.p[1] - 300.0 * math.pi / 2)))
    P = _pinned_periodic_reduction(space, long_case.supports, pin=far)
    U = P @ factorize((P.T @ A @ P).tocsr()).solve(P.T @ F)
    tl = time.perf_counter() - t0
    sol = ShellSolution(space=space, U=U, A=A, F=F)
    wl = sol.evaluate([0.0, 0.0], [0.0, math.pi], ("w",))["w"]
    pin_reaction = (A @ U - F)[far]

    print("\npinched cylinder: w under the load (reference -1.8248e-5)")
    print(
        f"  1/8 model             {r8.solution.space.ndofs:6d} dofs  w = {w8:.8e}  err {(-w8 - PINCHED) / PINCHED:+.2e}"
        f"  {t8:.2f} s"
    )
    print(f"  full, half length     {rf.solution.space.ndofs:6d} dofs  w = {wf[0]:.8e}, {wf[1]:.8e}  {tf:.2f} s")
    print(
        f"  full, full length     {space.ndofs:6d} dofs  w = {wl[0]:.8e}, {wl[1]:.8e}  {tl:.2f} s"
        f"  (pin reaction {pin_reaction:.1e})"
    )
    agree = max(abs(w - w8) for w in (*wf[:2], *wl)) / abs(w8)
    print(f"  largest difference to the 1/8 model: {agree:.1e} relative")
    for w in (w8, *wf[:2], *wl):
        assert abs((-w - PINCHED) / PINCHED) < 8e-3  # measured −1.55e-3
        assert abs(w - w8) < 5e-11 * abs(w8)  # measured 6.0e-12
    assert abs(pin_reaction) < 5e-12  # measured 7.7e-13 (the load is 1)


# ---------------------------------------------------------------------------------------------
# work-consistent loads: applied totals = support reactions
# ---------------------------------------------------------------------------------------------
def test_dead_load_equals_reactions(examples_dir):
    """Scordelis–Lo dead load: total 90 × area (analytic) = resultant of all support reactions."""
    case = sc.load_case(examples_dir / "scordelis_lo.toml")
    sh = case.shell
    total = np.array([0.0, 0.0, -90.0 * sh.length * sh.radius * (sh.beta - sh.alpha)])
    print(f"\ndead load: analytic total {total[2]:.6f}")
    errs = []
    for n in (4, 8, 16):
        sol = sc.solve(_with_mesh(case, nx=n, nphi=n)).solution
        R = sol.reaction_resultant()
        applied = np.array(
            [sol.F @ sol.space.interpolate(rigid_motion(sh, np.eye(3)[k], np.zeros(3))) for k in range(3)]
        )
        errs.append(np.abs(R + total).max() / abs(total[2]))
        print(f"  {n:2d}x{n:<2d}  F.I_h(e) = {applied}  reactions = {R}  |R + total|/|total| = {errs[-1]:.2e}")
        assert np.abs(applied - total).max() < 1e-5 * abs(total[2])
    assert errs[-1] < 1e-5
    assert errs[2] < errs[1] < errs[0]


PANEL = Shell(
    radius=2.0,
    length=3.0,
    thickness=0.05,
    material=Isotropic(1.0e3, 0.3),
    alpha=math.radians(20.0),
    beta=math.radians(110.0),
    x_start=-1.0,
)


def _line_and_point_loads(sh: Shell):
    """Loads on PANEL with their analytic global totals."""
    a, al, be = sh.radius, sh.alpha, sh.beta
    x0, phi0 = 0.5, math.radians(50.0)
    items = {
        # ring line load along x = x0 with a φ-dependent normal intensity q(φ) = cos φ
        "line x=const, normal cos(phi)": (
            LineLoad(x=x0, normal=lambda x, phi: np.cos(phi)),
            a
            * np.array(
                [
                    0.0,
                    0.5 * (be - al) + 0.25 * (math.sin(2 * be) - math.sin(2 * al)),
                    0.25 * (math.cos(2 * al) - math.cos(2 * be)),
                ]
            ),
        ),
        # a constant global force per unit length along the generator φ = φ0
        "line phi=const, force": (
            LineLoad(phi=phi0, force=(0.3, -1.0, 2.0)),
            sh.length * np.array([0.3, -1.0, 2.0]),
        ),
        # force varying along the generator: f(x) = (0, 0, x)
        "line phi=const, f(x)": (
            LineLoad(phi=phi0, force=lambda x, phi: np.stack([0 * x, 0 * x, x])),
            np.array([0.0, 0.0, 0.5 * (sh.x_max**2 - sh.x_min**2)]),
        ),
    }
    return items, x0, phi0


def test_line_and_point_loads_are_work_consistent(rates):
    """Line loads along x = const and φ = const and point loads: F · I_h(e_k) and the reactions
    equal the analytic totals, with errors decreasing under refinement."""
    sh = PANEL
    items, x0, phi0 = _line_and_point_loads(sh)
    point = PointLoad(x=-0.37, phi=math.radians(77.0), force=(1.0, 2.0, -3.0))  # inside an element
    items["point (inside an element)"] = (point, np.array(point.force))
    print("\nload                          mesh  |F.I_h(e) - total|  |R + total|   (relative)")
    for name, (load, total) in items.items():
        errs_app, errs_r = [], []
        for n in (4, 8, 16):
            xs = np.unique(np.r_[np.linspace(sh.x_min, sh.x_max, n + 1), x0])
            ss = np.unique(np.r_[np.linspace(sh.s_min, sh.s_max, n + 1), sh.radius * phi0])
            mesh = structured(sh, len(xs) - 1, len(ss) - 1, x_nodes=xs, s_nodes=ss)
            loads = Loads(points=(load,)) if isinstance(load, PointLoad) else Loads(lines=(load,))
            space = ShellSpace(mesh)
            A = model.stiffness(space)
            F = load_vector(space, loads)
            red = Reduction.build(space, Supports())
            U = red.expand(factorize(red.reduce_matrix(A)).solve(red.reduce_vector(F)))
            sol = ShellSolution(space=space, U=U, A=A, F=F)
            applied = np.array([F @ space.interpolate(rigid_motion(sh, np.eye(3)[k], np.zeros(3))) for k in range(3)])
            scale = np.linalg.norm(total)
            errs_app.append(np.linalg.norm(applied - total) / scale)
            errs_r.append(np.linalg.norm(sol.reaction_resultant() + total) / scale)
            print(f"{name:30s} {n:2d}x{n:<2d} {errs_app[-1]:14.2e} {errs_r[-1]:14.2e}")
        assert errs_app[-1] < 1e-5 and errs_r[-1] < 1e-5, name
        assert errs_r[2] < errs_r[1] < errs_r[0], name
        if errs_app[0] > 1e-12:
            assert errs_app[2] < errs_app[1] < errs_app[0], name


def test_line_load_equals_limit_of_point_loads():
    """A line load along φ = φ0 does the same work as many point loads spread along the line."""
    sh = PANEL
    phi0 = math.radians(50.0)
    xs = np.unique(np.r_[np.linspace(sh.x_min, sh.x_max, 9), 0.5])
    ss = np.unique(np.r_[np.linspace(sh.s_min, sh.s_max, 9), sh.radius * phi0])
    space = ShellSpace(structured(sh, len(xs) - 1, len(ss) - 1, x_nodes=xs, s_nodes=ss))
    f = np.array([0.3, -1.0, 2.0])
    F_line = load_vector(space, Loads(lines=(LineLoad(phi=phi0, force=tuple(f)),)))
    # midpoint rule with m points: F_points → F_line like m^-2
    diffs = []
    for m in (50, 100, 200):
        x = sh.x_min + (np.arange(m) + 0.5) * sh.length / m
        pts = tuple(PointLoad(float(xi), phi0, tuple(f * sh.length / m)) for xi in x)
        F_pts = load_vector(space, Loads(points=pts))
        diffs.append(np.linalg.norm(F_pts - F_line) / np.linalg.norm(F_line))
    print(f"\nline load vs m point loads (m = 50, 100, 200): relative differences {np.array(diffs)}")
    assert diffs[-1] < 1e-3
    assert diffs[0] / diffs[-1] > 10.0  # second order in 1/m

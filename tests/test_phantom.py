"""Phantom experiments: determinism, ground-truth consistency, constraints, committed params."""

from __future__ import annotations

import hashlib
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from tendrilkit import phantom as P
from tendrilkit.phantom.constraints import _visible
from tendrilkit.phantom.projection import _mm_per_px, _project_safe
from tendrilkit.phantom.render import static_layers
from tendrilkit.params import load_experiment, parse_experiment

ROOT = Path(__file__).resolve().parents[1]


def _digest(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.slow
def test_write_is_deterministic_and_skips_when_present(tmp_path):
    a = P.write_phantom_experiment("S3", tmp_path / "a", n_frames=2, seed=0)
    # nothing is cached between calls: b is a fresh generation
    b = P.write_phantom_experiment("S3", tmp_path / "b", n_frames=2, seed=0)
    da, db = _digest(a.parent), _digest(b.parent)
    assert set(da) >= {"view1.mp4", "view2.mp4", "view3.mp4", "experiment.yaml", "ground_truth/gt_curves.csv"}
    assert da == db
    # a second call with the same arguments leaves the files alone
    mtime = (a.parent / "view1.mp4").stat().st_mtime_ns
    P.write_phantom_experiment("S3", tmp_path / "a", n_frames=2, seed=0)
    assert (a.parent / "view1.mp4").stat().st_mtime_ns == mtime
    # the experiment file is valid, its videos are readable and hold the frames
    exp = load_experiment(a)
    assert exp.name == "phantom-S3" and exp.stimulation_site == "S3" and len(exp.videos) == 3
    assert any(c.dist[0] != 0 for c in exp.cameras)
    cap = cv2.VideoCapture(str(exp.videos[0]))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 2
    ok, img = cap.read()
    cap.release()
    assert ok and img.shape == (1080, 1920, 3)
    # after compression the frame is still the rendered one, up to a few grey levels
    rendered = P.render_view(P.make_phantom("S3", n_frames=2, seed=0), 0, 0).astype(float)
    err = np.abs(img.astype(float) - rendered)
    assert err.mean() < 4.0 and np.percentile(err, 99) < 15, (err.mean(), np.percentile(err, 99))


def test_ground_truth_round_trip(tmp_path):
    ph = P.make_phantom("S2", n_frames=3, seed=0)
    P.write_ground_truth(ph, tmp_path)
    gt = P.read_ground_truth(tmp_path)
    assert gt.curves.shape == ph.curves_mm.shape
    np.testing.assert_allclose(gt.curves, ph.curves_mm, atol=1e-6)
    np.testing.assert_allclose(gt.projections, ph.projections_px, atol=1e-4)
    assert gt.meta["site"] == "S2" and gt.meta["n_frames"] == 3
    # projections are the cameras' projections of the curves
    for v, cam in enumerate(gt.cameras):
        np.testing.assert_allclose(cam.project(gt.curves[2]), gt.projections[2, v], atol=1e-3)
    # the laws rebuild the curve: integrating them gives the stored centreline
    f = 2
    for kind, law in (("kappa", ph.kappa[f]), ("tau", ph.tau[f])):
        rows = gt.laws[(gt.laws.frame == f) & (gt.laws.kind == kind)].sort_values("segment")
        np.testing.assert_allclose(rows.s0_mm.to_numpy(), law.knots_mm[:-1], atol=1e-6)
        np.testing.assert_allclose(rows.value_s0.to_numpy(), law.values[:-1], rtol=1e-6, atol=1e-9)


def test_centreline_has_the_laws_curvature_and_torsion():
    """Finite-difference curvature/torsion of the dense centreline equal the laws."""
    ph = P.make_phantom("S3", n_frames=2, seed=0)
    f = 1
    c, s = ph.curves_mm[f], ph.s_mm
    h = s[1] - s[0]
    d1 = np.gradient(c, h, axis=0)
    d2 = np.gradient(d1, h, axis=0)
    d3 = np.gradient(d2, h, axis=0)
    cr = np.cross(d1, d2)
    kappa = np.linalg.norm(cr, axis=1)
    tau = np.einsum("ij,ij->i", cr, d3) / np.maximum(kappa**2, 1e-12)
    inner = slice(8, -8)
    np.testing.assert_allclose(np.linalg.norm(d1, axis=1)[inner], 1.0, atol=5e-4)  # O(h^2 kappa^2) differences
    np.testing.assert_allclose(kappa[inner], ph.kappa[f](s)[inner], atol=2e-3)
    curl = ph.kappa[f](s) > 0.05  # torsion is only defined where the curve bends
    np.testing.assert_allclose(tau[curl][4:-4], ph.tau[f](s)[curl][4:-4], atol=5e-3)


def test_rendered_tendril_lies_on_its_projection():
    ph = P.make_phantom("S3", n_frames=3, seed=0)
    f = 2
    for v, cam in enumerate(ph.cameras):
        img = P.render_view(ph, f, v)
        blue = img[:, :, 0].astype(float)
        proj = ph.projections_px[f, v]
        r_px = 0.5 * ph.diameter_mm / _mm_per_px(cam, ph.curves_mm[f].mean(axis=0))
        x0, y0, w, h = ph.views[v]["roi"]
        x, y = np.meshgrid(np.arange(x0, x0 + w), np.arange(y0, y0 + h))
        # the tendril's pixels: dark in blue here, not dark in the static scene (stem, leaves, markers)
        background = static_layers(ph, v)["blurred"][y0:y0 + h, x0:x0 + w, 0]
        dark = (blue[y0:y0 + h, x0:x0 + w] < 120) & (background > 150)
        pts = np.stack([x[dark], y[dark]], axis=1).astype(float)
        from scipy.spatial import cKDTree

        d_pix, _ = cKDTree(proj).query(pts)
        near_base = np.linalg.norm(pts - proj[0], axis=1) < 40
        far = d_pix[~near_base]
        assert far.size > 500
        assert far.max() <= r_px + 1.5, (v, far.max(), r_px)
        # and every projected centreline point lies on dark pixels
        px = np.round(proj).astype(int)
        on = blue[px[:, 1], px[:, 0]] < 120
        assert on[ph.s_mm > 1.5].all(), (v, np.flatnonzero(~on))


def test_s3_default_crosses_itself_in_two_views():
    ph = P.make_phantom("S3", n_frames=6, seed=0)
    final = [f for f in range(ph.n_frames) if ph.time_s[f] >= ph.design.stable_s]
    assert final
    for f in final:
        views = [v for v in range(3) if any(_visible(c, ph.length_mm) for c in ph.crossings[f][v])]
        assert len(views) >= 2, (f, ph.crossings[f])
    # the planar sites never cross themselves
    for site in ("S2", "S4"):
        p = P.make_phantom(site, n_frames=4, seed=0)
        assert not any(c for cf in p.crossings for c in cf)


@pytest.mark.parametrize("site,seed", [("S2", 3), ("S3", 5), ("S4", 11)])
def test_constraints_hold_for_other_seeds(site, seed):
    ph = P.make_phantom(site, n_frames=4, seed=seed)
    assert 120 <= ph.length_mm <= 200
    assert P.check_constraints(ph.curves_mm, ph.s_mm, ph.cameras, site, time_s=ph.time_s,
                               stable_s=ph.design.stable_s, diameter_mm=ph.diameter_mm) == []
    assert ph.curves_mm[..., 2].min() >= 3.0
    assert ph.name == f"phantom-{site}-seed{seed}"
    for v, cam in enumerate(ph.cameras):
        assert cam.in_image(ph.projections_px[:, v].reshape(-1, 2), margin_px=60).all()
        for mk in ph.scene.markers:
            assert cam.in_image(cam.project(mk.corners_mm(9 / 7)), margin_px=30).all()
    assert ph.scene.markers[0].id == 815 and 4 <= len(ph.scene.markers) <= 6
    assert np.all(ph.hidden_base_mm <= 3.0)


def test_committed_params_match_the_generator():
    for site in P.SITES:
        text = (ROOT / "params" / f"phantom_{site}.yaml").read_text(encoding="utf-8")
        assert text == P.phantom_params_yaml(site, video_dir=f"../data/phantoms/{site}"), site
        # valid (the videos themselves exist only once the demo has generated them)
        assert parse_experiment(yaml.safe_load(text)).name == f"phantom-{site}"


@pytest.mark.slow
def test_design_and_marks_do_not_depend_on_the_sequence_length():
    short = P.make_phantom("S4", n_frames=3, seed=0)
    default = P.make_phantom("S4", seed=0)
    assert short.views == default.views and short.length_mm == default.length_mm
    assert [m.id for m in short.scene.markers] == [m.id for m in default.scene.markers]
    # the same time gives the same curve
    np.testing.assert_allclose(short.curves_mm[0], default.curves_mm[0])
    assert short.fps == pytest.approx(3 / 900, rel=1e-6) and default.fps == pytest.approx(1 / 15, rel=1e-6)
    # the response starts after the onset and is (up to the wobble) complete after stabilisation
    r, t = default.response, default.time_s
    assert r[t < default.design.onset_s].max() < 0.03
    for site in P.SITES:  # hanging almost straight before the onset
        ph = P.make_phantom(site, n_frames=3, seed=0)
        assert ph.kappa[0].values.max() <= 0.005 and np.abs(ph.tau[0].values).max() <= 0.005
    assert np.all(np.abs(r[t >= default.design.stable_s] - 1) < 0.06)
    # another seed is another tendril
    assert P.make_phantom("S4", n_frames=3, seed=1).length_mm != short.length_mm


def test_bad_arguments_raise():
    with pytest.raises(P.PhantomError, match="site"):
        P.make_phantom("S5")
    with pytest.raises(P.PhantomError, match="unknown phantom option"):
        P.make_phantom("S1", n_frames=2, colour="red")


def test_points_beyond_the_field_of_view_are_not_folded_into_the_image():
    """The distortion polynomial folds back at wide angles (k1, k2 < 0): such points must not be drawn."""
    from tendrilkit.camera import Camera

    cam = Camera(K=np.array([[1750.0, 0, 960], [0, 1750.0, 540], [0, 0, 1]]), dist=[-0.06, -0.02, 0, 0, 0])
    far = np.array([[2.2 * 400.0, 0.0, 400.0]])  # 65 degrees off axis
    assert cam.in_image(cam.project(far)).all()  # the model's fold puts it inside the image
    assert np.isnan(_project_safe(cam, far)).all()
    inside = np.array([[50.0, 20.0, 400.0]])
    np.testing.assert_allclose(_project_safe(cam, inside), cam.project(inside))


def test_phantom_is_read_only_and_its_layers_go_with_it():
    """No global cache: a phantom's arrays cannot be changed by a reader, and its rendered layers die with it."""
    import gc
    import weakref

    ph = P.make_phantom("S1", n_frames=2, seed=0)
    for a in (ph.curves_mm, ph.projections_px, ph.s_mm, ph.time_s, ph.response, ph.kappa[0].values, ph.tau[1].values):
        with pytest.raises(ValueError, match="read-only"):
            a[..., 0] = 0.0
    P.render_view(ph, 0, 1)
    layers = static_layers(ph, 1)
    with pytest.raises(ValueError, match="read-only"):
        layers["blurred"][0, 0, 0] = 0.0
    assert static_layers(ph, 1) is layers  # drawn once per view
    ref = weakref.ref(ph)
    del ph, layers
    gc.collect()
    assert ref() is None


def test_true_centreline_agrees_with_the_methods_integrator():
    """The ground truth's DOP853 solution and frenet.integrate_frenet (rotation steps on the law's step means)."""
    from tendrilkit.frenet import integrate_frenet

    ph = P.make_phantom("S3", n_frames=3, seed=0)
    f, s, F0 = 2, ph.s_mm, ph.design.frame0
    X, *_ = integrate_frenet(s, ph.kappa[f].step_means(s), ph.tau[f].step_means(s), F0[0], F0[1], F0[2],
                             ph.curves_mm[f, 0], step_values=True, positions="exact")
    # measured 0.75 micrometres over the 175 mm loop
    assert np.linalg.norm(X - ph.curves_mm[f], axis=1).max() < 2e-3


def test_solve_frenet_serret_checks_its_laws():
    from tendrilkit.pwc import PiecewiseLinearLaw

    a = PiecewiseLinearLaw(np.array([0.0, 10.0]), np.zeros(2))
    b = PiecewiseLinearLaw(np.array([0.0, 5.0, 10.0]), np.zeros(3))
    s = np.linspace(0, 10, 11)
    with pytest.raises(ValueError, match="same breakpoints"):
        P.solve_frenet_serret(s, [a, b], [a, a], np.zeros(3), np.eye(3))
    with pytest.raises(ValueError, match="one law of each per frame"):
        P.solve_frenet_serret(s, [a, a], [a], np.zeros(3), np.eye(3))
    # a circle of radius 10 mm closes after 2 pi r
    k = PiecewiseLinearLaw(np.array([0.0, 20 * np.pi]), np.full(2, 0.1))
    X = P.solve_frenet_serret(np.linspace(0, 20 * np.pi, 401), [k], [a], np.zeros(3), np.eye(3))[0]
    assert np.abs(X[-1]).max() < 1e-6 and abs(np.linalg.norm(X[100] - [0, 10, 0]) - 10) < 1e-6

"""Calibration accuracy and speed on rendered frames and on phantom experiments.

    .venv/bin/python benchmarks/bench_calibration.py corners    # refinement methods compared
    .venv/bin/python benchmarks/bench_calibration.py synthetic  # single marker vs bundle adjustment
    .venv/bin/python benchmarks/bench_calibration.py speed      # time of one bundle adjustment
    .venv/bin/python benchmarks/bench_calibration.py phantom [SITES] [--seeds 0,1]
    .venv/bin/python benchmarks/bench_calibration.py scenes --seeds 0:200 [--configs edges:1,grid:5] [--cache DIR]
    .venv/bin/python benchmarks/bench_calibration.py corner-noise --seeds 0:70 [--cache DIR]

``scenes``: random scenes (:mod:`tendrilkit.phantom.scenes`, dev seeds only)
generated and calibrated, no reconstruction: per view the rig's max px over
the tendril's points against the true cameras, its spread on the marks'
volume and the flags (:func:`tendrilkit.calibration.assess_rig`).
Measured 2026-11-30 (scenes of 6 frames, the shared machine), the worst
view's rig px per scene. Tuning seeds 0:70, frame 0 alone: ``edges`` median
0.130, max 0.679, 5 scenes over 0.5 px (1 not flagged), 20 flagged (16 of
them within 0.5 px); ``grid`` 0.130 / 0.451, none over, 15 flagged (all
within 0.5 px). The default, ``grid`` on 5 frames (``--configs grid:5``):
0.088 / 0.387, none over, 7 flagged (all within 0.5 px); calibration CPU
2.2 s per scene (median; ``grid`` on one frame about 0.8 s). Untouched
dev ranges, measured once (29 of 30 calibrated each: in 6013 and 8003 the
stem and its tape cover the world marker in view 1): 6000:6030 ``edges`` x 1
0.163 / 0.544, 1 over (flagged), 13 flagged; ``grid`` x 5 0.089 / 0.458, none
over, 6 flagged. 8000:8030 ``edges`` x 1 0.127 / 0.497, none over, 6
flagged; ``grid`` x 5 0.072 / 0.366, none over, 3 flagged.
After the generator's world-marker check (6013 and 8003 redrawn), measured
2026-11-30 at load 17-25: 0:70 ``grid`` x 5 unchanged (median 0.088, max
0.387, none over, 7 flagged, all within 0.5 px); the untouched range
9300:9340, measured once: 40 of 40 calibrated, median 0.083, max 0.402,
none over, 7 flagged (all within 0.5 px; the worst, 9334, flagged). The
worst scenes have the ``markers`` factor: a 16-20 mm world marker (75-95 px)
with one or two small shared markers (40-80 px), one more seen by a single
view (9334, 9338, 65), or a glancing card as the main shared marker
(38: aspect 2.2, 13 mm off the board, |k1| up to 0.097). There the spread
can be low by 2-2.7x (65: 0.36 px at spread 0.15, residual sigma 0.009 px;
38: 0.39 at 0.23): on 0:70 max/spread median 0.96, max 2.67; on 9300:9340
median 0.76, max 2.2.
After the corner-noise model (``corner-noise`` below; the adjustment weighs
each marker's corners by one over their expected error and floors its noise
estimate at the model's), measured 2026-11-30 at load 25-33, ``grid`` x 5:
0:70 median 0.088, max 0.364 (38, the glancing card: 0.387 -> 0.212), none
over, 7 flagged (the two worst, 65 at 0.364 and 38, among them; before, the
flags went to seven scenes of 0.12-0.24 px), worst unflagged 0.301 (56,
2 x spread 0.47); true/spread (per view, largest per scene) median 0.81,
90th percentile 1.52, max 2.56 (seed 24; before 0.94 / 1.81 / 3.47); 65:
spread 0.167 -> 0.301 (noise 0.009 -> 0.016 px). With corners drawn from the
model itself (exact first-order covariance but for linearisation) the same
ratio is 0.81 / 1.41 / 2.02: the model is honest up to a slightly heavier
tail. The untouched range 9600:9640, measured once: 40 of 40 calibrated,
median 0.093, max 0.204, none over, none flagged; true/spread median 0.92,
90th percentile 1.62, max 2.59 (9635), 2 scenes over 2. The same scenes with
the code before (same run): median 0.104, max 0.212, 3 flagged (all under
0.25 px), true/spread 1.06 / 2.16 / 2.65, 6 over 2; the glancing cards of
9601, 9631 and 9632 now weigh less: 0.16 -> 0.07, 0.20 -> 0.07, 0.14 -> 0.09 px.

``corner-noise``: the ``grid`` corners (averaged over the 5 cached frames)
against the generator's true corners per marker observation; the data of
:func:`tendrilkit.calibration.markers.corner_sigma_px` (0:70: per-coordinate
rms 0.013 px at a side of 100 px for aspect ratios under 1.35, 927
observations; 33 foreshortened ones, aspect to 3.7, up to 15 times more).

``synthetic``: exact corners plus noise; camera rotation error and agreement
of the single-marker poses and of the bundle adjustment.

``corners``: the board of tendrilkit.calibration.synthetic rendered through the
IJCV25 rig with lens distortion at several blur levels; per corner refinement
method, the corner error against the exact projection, the single-marker
rotation error of the world marker's pose, and the calibrated rig's agreement
with the true rig on working-volume points (single-marker and adjusted).

``phantom``: writes a short phantom experiment per site and seed
(:func:`tendrilkit.phantom.write_phantom_experiment`), calibrates it and
compares the rig with ``ground_truth/true_cameras.json`` on the ground-truth
centreline points: the paper's way (OpenCV corners, world marker alone, no
distortion), tendrilkit's single-marker poses and the adjusted rig.
"""

from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tendrilkit.camera import Camera  # noqa: E402
from tendrilkit.calibration import calibrate, calibrate_from_observations, detect_markers, marker_pose, rig_agreement_px  # noqa: E402


def bench_corners() -> None:
    from tendrilkit.calibration import synthetic as T

    cams = T.distorted_rig()
    tex, corners = T.board_scene()
    P = T.working_volume()
    print(f"{'blur':>4} {'method':>8} {'corner mean':>11} {'max':>6} {'rot deg':>7} {'single px':>9} {'adjusted px':>11} {'detect ms':>9}")
    for blur in (0.7, 1.2, 2.0):
        rng = np.random.default_rng(11)
        images = [T.render_board(c, tex, rng=rng, blur_px=blur, noise=2.5, corners=corners) for c in cams]
        for method in ("none", "subpix", "contour", "apriltag", "edges"):
            errs, rots, obs = [], [], {}
            t0 = time.perf_counter()
            for v, (cam, img) in enumerate(zip(cams, images)):
                obs[v] = detect_markers(img, T.DICT, refine=method, camera=cam)
            dt = (time.perf_counter() - t0) / len(cams) * 1000
            for v, cam in enumerate(cams):
                for mid, c in obs[v].items():
                    errs.append(np.linalg.norm(c - cam.project(corners[mid]), axis=1))
                R, _ = marker_pose(obs[v][T.WORLD_ID], cam, T.L)
                rots.append(T.rot_err_deg(R, cam.R))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = calibrate_from_observations(obs, cams, world_id=T.WORLD_ID, length_mm=T.L)
            s, _ = rig_agreement_px(res.single_cameras, cams, P)
            a, _ = rig_agreement_px(res.cameras, cams, P)
            e = np.concatenate(errs)
            print(f"{blur:4.1f} {method:>8} {e.mean():11.3f} {e.max():6.3f} {max(rots):7.3f} {s.max():9.2f} {a.max():11.3f} {dt:9.0f}")


def bench_synthetic(seeds: int = 20) -> None:
    """Pose error (deg) and working-volume agreement (px) of single-marker vs adjusted
    poses on exact corners plus Gaussian noise, the markers of tendrilkit.calibration.synthetic."""
    from tendrilkit.calibration import synthetic as T
    from tendrilkit.calibration import bundle_adjust

    P = T.working_volume()
    print(f"{'sigma px':>8} {'single deg (median/max)':>24} {'adjusted deg':>14} {'single px':>12} {'adjusted px':>12} {'BA ms':>6}")
    for sigma in (0.05, 0.1, 0.3, 0.5):
        rows = []
        for seed in range(seeds):
            rng = np.random.default_rng(seed)
            truth = T.distorted_rig()
            obs = T.observe_markers(truth, T.synthetic_markers(rng), rng, sigma)
            single = [c.with_pose(*marker_pose(obs[v][T.WORLD_ID], c, T.L)) for v, c in enumerate(truth)]
            t0 = time.perf_counter()
            cams, _ = bundle_adjust(single, obs, world_id=T.WORLD_ID, length_mm=T.L)
            dt = time.perf_counter() - t0
            rows.append((max(T.rot_err_deg(a.R, b.R) for a, b in zip(single, truth)),
                         max(T.rot_err_deg(a.R, b.R) for a, b in zip(cams, truth)),
                         rig_agreement_px(single, truth, P)[0].max(), rig_agreement_px(cams, truth, P)[0].max(), dt * 1000))
        r = np.array(rows)
        med, mx = np.median(r, 0), r.max(0)
        print(f"{sigma:8.2f} {med[0]:11.3f}/{mx[0]:<12.3f} {med[1]:6.3f}/{mx[1]:<7.3f} {med[2]:5.2f}/{mx[2]:<6.2f} "
              f"{med[3]:5.2f}/{mx[3]:<6.2f} {med[4]:6.0f}")


def bench_bundle_speed(repeats: int = 5) -> None:
    """Time of one bundle adjustment on the perturbed rig of
    tests/test_calibration.py::test_bundle_adjust_recovers_perturbed_rig (1.5 degrees and
    3 mm off, 0.05 px noise); that test asserted ``elapsed < 5`` s, which belongs here."""
    from tendrilkit.calibration import synthetic as T
    from tendrilkit.calibration import bundle_adjust
    from tendrilkit.camera import rotation_from_rvec

    rng = np.random.default_rng(7)
    truth = T.distorted_rig()
    obs = T.observe_markers(truth, T.synthetic_markers(rng), rng, 0.05)
    start = []
    for c in truth:
        dR = rotation_from_rvec(rng.normal(size=3) * np.radians(1.5) / np.sqrt(3))
        start.append(c.with_pose(dR @ c.R, c.t_mm + rng.normal(0, 3 / np.sqrt(3), 3)))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        _, rep = bundle_adjust(start, obs, world_id=T.WORLD_ID, length_mm=T.L)
        times.append(time.perf_counter() - t0)
    print(f"bundle adjustment, perturbed rig: median {np.median(times):.2f} s, max {max(times):.2f} s over {repeats} runs "
          f"({rep.nfev} evaluations, rms {rep.rms_before_px:.2f} -> {rep.rms_after_px:.3f} px)")


def bench_phantom(sites: list[str], seeds: list[int], n_frames: int = 2) -> None:
    from tendrilkit.extrinsics import calibrate_experiment
    from tendrilkit.io import read_cameras, read_csv
    from tendrilkit.params import load_experiment
    from tendrilkit.phantom import write_phantom_experiment

    print(f"{'site':>4} {'seed':>4} {'paper max px':>20} {'single max px per view':>26} {'adjusted max px per view':>28} {'mean adj':>8} {'on plane':>10} {'s':>5}")
    for site in sites:
        for seed in seeds:
            with tempfile.TemporaryDirectory() as d:
                path = write_phantom_experiment(site, Path(d) / site, n_frames=n_frames, seed=seed)
                exp = load_experiment(path)
                t0 = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    res = calibrate_experiment(exp)
                dt = time.perf_counter() - t0
                gt = Path(path).parent / "ground_truth"
                truth = read_cameras(gt / "true_cameras.json")
                curves = read_csv(gt / "gt_curves.csv")
                pts = curves[["x_mm", "y_mm", "z_mm"]].to_numpy()
                s, _ = rig_agreement_px(res.single_cameras, truth, pts)
                # the paper's way: OpenCV corners, the world marker alone, no lens distortion
                from tendrilkit.calibration import experiment_intrinsics
                from tendrilkit.io import FrameSource

                images, sizes = [], []
                for video in exp.videos:
                    with FrameSource(video) as src:
                        images.append(src.read(exp.frames.start))
                        sizes.append((src.width, src.height))
                intr = [Camera(c.K, np.zeros(5), width=c.width, height=c.height) for c in experiment_intrinsics(exp, sizes)]
                paper = calibrate(images, intr, dictionary=exp.marker.dictionary, world_id=exp.marker.id,
                                  length_mm=exp.marker.length_mm, bundle_adjust=False, refine="subpix")
                pp, _ = rig_agreement_px(paper.cameras, truth, pts)
                a, am = rig_agreement_px(res.cameras, truth, pts)
                n_markers = {v: len(o) for v, o in res.observations.items()}

                def rot_deg(cams):
                    return max(np.degrees(np.arccos(np.clip((np.trace(a.R.T @ b.R) - 1) / 2, -1, 1)))
                               for a, b in zip(cams, truth))

                degs = f"rot deg paper {rot_deg(paper.cameras):.3f} single {rot_deg(res.single_cameras):.3f} adjusted {rot_deg(res.cameras):.4f}"
                print(f"{site:>4} {seed:4d} {np.array2string(pp, precision=1):>20} {np.array2string(s, precision=2):>26} {np.array2string(a, precision=2):>28} "
                      f"{am.max():8.2f} {len(res.bundle.on_plane) if res.bundle else 0:>10} {dt:5.1f}  {degs}  markers/view {n_markers} ids {sorted(set().union(*[set(o) for o in res.observations.values()]))}")


def _scene_frames(seed: int, cache: Path, n_frames: int = 6, n_images: int = 5) -> Path:
    """The first ``n_images`` frames of every view of a random scene of ``n_frames`` frames, through an
    mp4v video as ``write_scene_experiment`` writes them (PNG ``view{v}_f{k}.png`` in ``cache/seed``),
    with the true rig, the tendril's points (every frame) and the marks."""
    import json

    import cv2

    d = cache / str(seed)
    if (d / "scene.npz").is_file():
        return d
    from tendrilkit.phantom.scenes import make_scene, render_scene_view

    ph = make_scene(seed, n_frames=n_frames)
    d.mkdir(parents=True, exist_ok=True)
    for v in range(len(ph.cameras)):
        with tempfile.TemporaryDirectory() as t:
            w = None
            for f in range(n_images):
                img = render_scene_view(ph, f, v)
                if w is None:
                    w = cv2.VideoWriter(f"{t}/a.mp4", cv2.VideoWriter_fourcc(*"mp4v"),
                                        float(ph.options["container_fps"]), (img.shape[1], img.shape[0]))
                w.write(img)
            w.release()
            cap = cv2.VideoCapture(f"{t}/a.mp4")
            for f in range(n_images):
                _, img = cap.read()
                cv2.imwrite(str(d / f"view{v + 1}_f{f}.png"), img)
            cap.release()
    (d / "marks.json").write_text(json.dumps([{"roi": [int(x) for x in v["roi"]], "base_point": v["base_point"]}
                                              for v in ph.views]))
    np.savez(d / "scene.npz", cameras=json.dumps([c.to_dict(i + 1) for i, c in enumerate(ph.cameras)]),
             X=np.asarray(ph.curves_mm).reshape(-1, 3), world_id=ph.scene.markers[0].id,
             length_mm=ph.scene.markers[0].length_mm, n_images=n_images)
    return d


def _scene_rig(seed: int, cache: str, refine: str, frames: int = 1) -> tuple[int, list | None, list | None, int, str, float]:
    """(seed, rig max px per view, spread px per view, flags, error, calibration CPU s) of one scene's
    calibration from its first ``frames`` frames."""
    import json

    import cv2

    from tendrilkit.calibration import assess_rig, marks_volume

    try:
        d = _scene_frames(seed, Path(cache))
    except Exception as e:  # a scene that is not generated is reported, the scan goes on
        return seed, None, None, 0, f"not generated: {e}", 0.0
    z = np.load(d / "scene.npz")
    truth = [Camera.from_dict(c) for c in json.loads(str(z["cameras"]))]
    intr = [Camera(c.K, c.dist, width=c.width, height=c.height) for c in truth]
    k = min(frames, int(z["n_images"]))
    images = [[cv2.imread(str(d / f"view{v + 1}_f{f}.png")) for f in range(k)] for v in range(len(truth))]
    marks = json.loads((d / "marks.json").read_text())
    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = calibrate(images, intr, dictionary="DICT_ARUCO_ORIGINAL", world_id=int(z["world_id"]),
                            length_mm=float(z["length_mm"]), refine=refine)
        except Exception as e:  # e.g. the world marker not found: reported, the scan goes on
            return seed, None, None, 0, f"not calibrated: {e}", 0.0
        vol = marks_volume(res.cameras, [m["base_point"] for m in marks], [m["roi"] for m in marks])
        res = assess_rig(res, vol, world_id=int(z["world_id"]), length_mm=float(z["length_mm"]))
    cpu = time.process_time() - t0
    mx, _ = rig_agreement_px(res.cameras, truth, z["X"])
    return seed, mx.tolist(), res.uncertainty_px.tolist(), len(res.flags), "", cpu


def bench_scenes(seeds: list[int], configs: list[tuple[str, int]], cache: str | None, workers: int) -> None:
    """Random scenes calibrated (no reconstruction): the rig's max px over the tendril's points per view.

    For every seed and configuration (corner refinement, frames averaged):
    the scene's first 5 frames (of 6; cached in ``cache``), :func:`calibrate` on the
    first ``frames`` of every view, :func:`assess_rig` on the marks' volume,
    and the largest distance between the tendril's points (every frame)
    projected through the calibrated and the true cameras, per view (what
    ``bench_generalize.py`` reports as ``rig_max_px_<v>``). Prints per seed,
    then per configuration the worst view's rig px per scene (median, max),
    the scenes over 0.5 px, those of them not flagged, the scenes flagged
    although within 0.5 px, and the calibration's CPU time (median per scene,
    three views, detection to assessment; frames already decoded).
    """
    from concurrent.futures import ProcessPoolExecutor

    if any(s_ >= 10000 for s_ in seeds):
        raise SystemExit("bench_calibration.py: error: seeds 10000 and above are reserved for bench_generalize.py")
    cache = cache or tempfile.mkdtemp(prefix="bench_calibration_scenes_")
    with ProcessPoolExecutor(max_workers=workers) as pool:  # generate the frames once, in parallel
        list(pool.map(_scene_frames_or_none, seeds, [cache] * len(seeds)))
        jobs = [(s_, r, k) for s_ in seeds for r, k in configs]
        out = list(pool.map(_scene_rig, [j[0] for j in jobs], [cache] * len(jobs), [j[1] for j in jobs],
                            [j[2] for j in jobs]))
    res = {(j[0], j[1], j[2]): o for j, o in zip(jobs, out)}
    table = {c: [] for c in configs}
    for seed in seeds:
        line = f"seed {seed:5d}"
        for r, k in configs:
            _, mx, u, nflag, err, cpu = res[(seed, r, k)]
            if mx is None:
                line += f" | {r}x{k}: {err}"
                table[(r, k)].append(None)
                continue
            ratio = max(a / b if b > 0 else np.inf for a, b in zip(mx, u))  # true over predicted, worst view
            table[(r, k)].append((max(mx), nflag > 0, mx, cpu, ratio, seed))
            line += f" | {r}x{k}: max px " + "/".join(f"{x:.2f}" for x in mx) + " spread " \
                + "/".join(f"{x:.2f}" for x in u) + (f" FLAGGED ({nflag} views)" if nflag else "")
        print(line, flush=True)
    print(f"seeds {seeds[0]}..{seeds[-1]} ({len(seeds)}), frames cached in {cache}")
    for (r, k), rows in table.items():
        failed = sum(x is None for x in rows)
        rows = [x for x in rows if x is not None]
        if not rows:
            continue
        worst = np.array([x[0] for x in rows])
        flagged = np.array([x[1] for x in rows])
        cpu = np.array([x[3] for x in rows])
        over = worst > 0.5
        ratio = np.array([x[4] for x in rows])
        unflagged = worst[~flagged].max() if (~flagged).any() else float("nan")
        print(f"{r:>6} x {k} frames: {len(rows)} scenes calibrated ({failed} not); worst view's rig px per scene: "
              f"median {np.median(worst):.3f}, max {worst.max():.3f}; over 0.5 px {int(over.sum())}, of them "
              f"not flagged {int((over & ~flagged).sum())}; flagged {int(flagged.sum())}, of them within 0.5 px "
              f"{int((flagged & ~over).sum())}, under 0.25 px {int((flagged & (worst < 0.25)).sum())}; worst "
              f"unflagged {unflagged:.3f} px; calibration CPU s per scene median {np.median(cpu):.2f}")
        print(f"{'':>6}   true px / predicted spread (per view, the largest per scene): median "
              f"{np.median(ratio):.2f}, 90th percentile {np.percentile(ratio, 90):.2f}, max {ratio.max():.2f} "
              f"(seed {rows[int(np.argmax(ratio))][5]}); scenes over 2: {int((ratio > 2).sum())}")


def _scene_corner_errors(seed: int, cache: str) -> list[tuple]:
    """Per marker observation of one scene: (seed, view, id, mean side px, aspect, corner errors (8,) px) of the
    ``grid`` corners averaged over the cached frames (as ``calibrate`` averages them), against the true corners
    (the generator's markers and cards projected through the true cameras)."""
    import json

    import cv2

    from tendrilkit.calibration import average_detections
    from tendrilkit.phantom.scenes import make_scene

    try:
        d = _scene_frames(seed, Path(cache))
    except Exception:  # a scene that is not generated is left out
        return []
    z = np.load(d / "scene.npz")
    truth = [Camera.from_dict(c) for c in json.loads(str(z["cameras"]))]
    ph = make_scene(seed, n_frames=6)
    corners = {m.id: m.corners_mm() for m in ph.scene.markers} | {c["id"]: np.asarray(c["corners_mm"], float)
                                                                 for c in ph.cards}
    out = []
    for v, cam in enumerate(truth):
        intr = Camera(cam.K, cam.dist, width=cam.width, height=cam.height)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            obs = average_detections([detect_markers(cv2.imread(str(d / f"view{v + 1}_f{f}.png")), "DICT_ARUCO_ORIGINAL",
                                                     camera=intr) for f in range(int(z["n_images"]))])
        for m, c in obs.items():
            if m not in corners:
                continue
            e = c - cam.project(corners[m])
            if np.abs(e).max() > 5:  # not that marker (an id the generator drew twice): left out
                continue
            m1 = np.linalg.norm((c[1] + c[2]) / 2 - (c[0] + c[3]) / 2)
            m2 = np.linalg.norm((c[2] + c[3]) / 2 - (c[0] + c[1]) / 2)
            side = float(np.mean(np.linalg.norm(np.roll(c, -1, 0) - c, axis=1)))
            out.append((seed, v + 1, int(m), side, float(max(m1, m2) / min(m1, m2)), e.ravel()))
    return out


def bench_corner_noise(seeds: list[int], cache: str | None, workers: int) -> None:
    """The ``grid`` corners' true error on random scenes, the data of
    :func:`tendrilkit.calibration.markers.corner_sigma_px`: per-coordinate rms scaled to a side of 100 px
    (times ``sqrt(side / 100)``) by aspect-ratio bins, and the model's fit above ``CORNER_SIGMA_ASPECT_FREE``."""
    from concurrent.futures import ProcessPoolExecutor

    from tendrilkit.calibration import markers as MK

    if any(s_ >= 10000 for s_ in seeds):
        raise SystemExit("bench_calibration.py: error: seeds 10000 and above are reserved for bench_generalize.py")
    cache = cache or tempfile.mkdtemp(prefix="bench_calibration_scenes_")
    with ProcessPoolExecutor(max_workers=workers) as pool:
        rows = [r for rs in pool.map(_scene_corner_errors, seeds, [cache] * len(seeds)) for r in rs]
    side = np.array([r[3] for r in rows])
    aspect = np.array([r[4] for r in rows])
    e100 = np.array([r[5] for r in rows]) * np.sqrt(side / 100.0)[:, None]  # (n, 8), scaled to a side of 100 px
    print(f"seeds {seeds[0]}..{seeds[-1]}: {len(rows)} marker observations (corners averaged over the cached frames)")
    for lo, hi in [(1.0, 1.2), (1.2, 1.35), (1.35, 2.0), (2.0, 2.6), (2.6, 10.0)]:
        s_ = (aspect >= lo) & (aspect < hi)
        if s_.any():
            print(f"aspect {lo:.2f}-{hi:.2f}: {int(s_.sum()):4d} observations, per-coordinate rms at 100 px "
                  f"{np.sqrt(np.mean(e100[s_] ** 2)):.4f}, median |e| {np.median(np.abs(e100[s_])):.4f}")
    face = aspect < MK.CORNER_SIGMA_ASPECT_FREE
    print(f"face-on (aspect < {MK.CORNER_SIGMA_ASPECT_FREE}): rms {np.sqrt(np.mean(e100[face] ** 2)):.4f} px at 100 px "
          f"(model CORNER_SIGMA_PX {MK.CORNER_SIGMA_PX}); 99th percentile of |e| {np.percentile(np.abs(e100[face]), 99):.4f}")
    if (~face).any():
        z = e100[~face] / ((aspect[~face] / MK.CORNER_SIGMA_ASPECT_FREE) ** MK.CORNER_SIGMA_ASPECT_POWER)[:, None]
        print(f"foreshortened: error over the model's growth, rms {np.sqrt(np.mean(z ** 2)):.4f}, median |e| "
              f"{np.median(np.abs(z)):.4f} (face-on median |e| {np.median(np.abs(e100[face])):.4f})")


def _scene_frames_or_none(seed: int, cache: str) -> None:
    try:
        _scene_frames(seed, Path(cache))
    except Exception:  # reported by _scene_rig
        pass


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "corners"
    if what == "scenes":
        import argparse

        ap = argparse.ArgumentParser(prog="bench_calibration.py scenes")
        ap.add_argument("--seeds", default="0:40", help="START:STOP, dev seeds only (0-9999)")
        ap.add_argument("--refine", default="grid,edges", help="corner refinements to compare")
        ap.add_argument("--frames", default="1", help="frames averaged per view to compare, e.g. 1,5 (at most 5)")
        ap.add_argument("--configs", default=None, help="instead of --refine x --frames: REFINE:FRAMES,... e.g. edges:1,grid:5")
        ap.add_argument("--cache", default=None, help="keep the scenes' frames here")
        ap.add_argument("--workers", type=int, default=2)
        a = ap.parse_args(sys.argv[2:])
        lo, hi = (int(x) for x in a.seeds.split(":"))
        configs = ([(c.split(":")[0], int(c.split(":")[1])) for c in a.configs.split(",")] if a.configs else
                   [(r, int(k)) for r in a.refine.split(",") for k in a.frames.split(",")])
        bench_scenes(list(range(lo, hi)), configs, a.cache, a.workers)
        raise SystemExit(0)
    if what == "corner-noise":
        import argparse

        ap = argparse.ArgumentParser(prog="bench_calibration.py corner-noise")
        ap.add_argument("--seeds", default="0:70", help="START:STOP, dev seeds only (0-9999)")
        ap.add_argument("--cache", default=None, help="the scenes' frames (as `scenes` caches them)")
        ap.add_argument("--workers", type=int, default=2)
        a = ap.parse_args(sys.argv[2:])
        lo, hi = (int(x) for x in a.seeds.split(":"))
        bench_corner_noise(list(range(lo, hi)), a.cache, a.workers)
        raise SystemExit(0)
    if what == "corners":
        bench_corners()
    elif what == "synthetic":
        bench_synthetic()
    elif what == "speed":
        bench_bundle_speed()
    else:
        sites = sys.argv[2].split(",") if len(sys.argv) > 2 and not sys.argv[2].startswith("--") else ["S1", "S2", "S3", "S4"]
        seeds = [0]
        if "--seeds" in sys.argv:
            seeds = [int(x) for x in sys.argv[sys.argv.index("--seeds") + 1].split(",")]
        bench_phantom(sites, seeds)

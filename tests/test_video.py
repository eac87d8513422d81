"""Orbit videos: cameras that look at the centre, frames that render and read back, the CLI."""

import re

import numpy as np
import pytest

from mitnerf.errors import MitnerfError
from mitnerf.viz.video import (OrbitConfig, depth_frames, orbit_cameras, orbit_video, read_video, render_orbit,
                               write_video)


class SphereBackend:
    """An analytic "model": a sphere of radius 0.5 at ``center``, opacity 0.8 where a ray hits it,
    colour = the hit normal mapped to [0, 1]; ``depth`` is ``opacity * t`` like a backend's sum w t."""

    def __init__(self, center=(0.0, 0.0, 0.0)):
        self.center = np.asarray(center)

    def render(self, o, d):
        oc = o - self.center
        b = np.einsum("pi,pi->p", oc, d)
        disc = b * b - (np.einsum("pi,pi->p", oc, oc) - 0.25)
        hit = disc > 0
        t = np.where(hit, -b - np.sqrt(np.maximum(disc, 0)), 0.0)
        n = (oc + t[:, None] * d) / 0.5
        a = np.where(hit, 0.8, 0.0)
        rgb = np.where(hit[:, None], 0.5 + 0.5 * n, 1.0)
        return {"rgb": rgb.astype(np.float32), "depth": (a * t).astype(np.float32), "opacity": a.astype(np.float32)}


def test_orbit_cameras_look_at_the_centre():
    c = np.array([0.2, -0.1, 0.3])
    cfg = OrbitConfig(n_frames=7, resolution=9, elevation=25.0, radius=3.5, fov=40.0, center=tuple(c))
    cams = orbit_cameras(cfg)
    assert len(cams) == 7 and (cams.height, cams.width) == (9, 9)
    assert cams.fov == pytest.approx(40.0)
    o, d = cams.rays()
    o, d = o[:, 4, 4], d[:, 4, 4]                        # centre pixel of an odd-sized image: the optical axis
    to_c = c - o
    miss = np.linalg.norm(to_c - np.einsum("ni,ni->n", to_c, d)[:, None] * d, axis=1)   # distance ray -> centre
    assert miss.max() < 1e-6
    assert np.all(np.einsum("ni,ni->n", to_c, d) > 0)    # in front of the camera
    rel = cams.origins - c
    np.testing.assert_allclose(np.linalg.norm(rel, axis=1), 3.5)
    np.testing.assert_allclose(rel[:, 2], 3.5 * np.sin(np.radians(25.0)))       # height 1.479
    az = np.degrees(np.arctan2(rel[:, 1], rel[:, 0])) % 360
    np.testing.assert_allclose(az, np.arange(7) * 360 / 7, atol=1e-9)            # one even turn from +x
    even = orbit_cameras(OrbitConfig(n_frames=3, resolution=10, center=tuple(c)))
    axis = -even.poses[:, :3, 2]                          # OpenGL: the camera looks down -z
    to_c = c - even.origins
    np.testing.assert_allclose(axis, to_c / np.linalg.norm(to_c, axis=1, keepdims=True), atol=1e-12)


def test_bad_orbits_are_refused():
    for bad, match in ((dict(n_frames=0), "--frames"), (dict(elevation=90.0), "--elevation"),
                       (dict(fov=0.0), "--fov"), (dict(radius=-1.0), "--radius")):
        with pytest.raises(MitnerfError, match=match):
            orbit_cameras(OrbitConfig(**bad))


def test_render_orbit_depth_is_depth_over_opacity():
    c = (0.1, 0.0, -0.2)
    cams = orbit_cameras(OrbitConfig(n_frames=5, resolution=11, radius=3.5, center=c))
    fr = render_orbit(SphereBackend(c), cams, batch_rays=300, progress=False)   # 2 frames per batch
    assert fr.rgb.shape == (5, 11, 11, 3) and fr.depth.shape == (5, 11, 11)
    # the centre ray of every frame hits the sphere at distance 3.5 - 0.5 = 3.0 (0.8 t / 0.8)
    np.testing.assert_allclose(fr.depth[:, 5, 5], 3.0, rtol=1e-6)
    assert np.isinf(fr.depth[:, 0, 0]).all()                                     # corners miss
    assert fr.fps > 0
    col = depth_frames(fr.depth, background=(1.0, 1.0, 1.0))
    np.testing.assert_array_equal(col[:, 0, 0], 1.0)                             # background where empty
    # the centre is the nearest point (depth 3.0 <= the 1st percentile): the near end of the scale,
    # viridis(1.0) (near = bright)
    from matplotlib import colormaps

    np.testing.assert_allclose(col[:, 5, 5], np.broadcast_to(colormaps["viridis"](1.0)[:3], (5, 3)), atol=1e-6)


def test_videos_read_back_with_the_right_frames(tmp_path):
    rng = np.random.default_rng(0)
    frames = rng.uniform(0, 1, (4, 15, 17, 3)).astype(np.float32)
    frames[:, :, :, :] = np.linspace(0, 1, 4)[:, None, None, None]               # frame k is grey k/3
    gif = read_video(write_video(tmp_path / "a.gif", frames, fps=10))
    assert gif.shape == (4, 15, 17, 3)
    np.testing.assert_allclose(gif[:, 0, 0, 0], [0, 85, 170, 255], atol=2)
    mp4 = read_video(write_video(tmp_path / "a.mp4", frames, fps=10))
    assert mp4.shape == (4, 16, 18, 3)                      # H.264 yuv420p: odd sizes padded to even
    np.testing.assert_allclose(mp4[:, 8, 8, 0], [0, 85, 170, 255], atol=6)      # lossy, but close
    with pytest.raises(MitnerfError, match="use .gif or .mp4"):
        write_video(tmp_path / "a.avi", frames)


@pytest.fixture(scope="module")
def tiny_checkpoint(vase_small, tmp_path_factory):
    """A 3D vanilla model (width 16, depth 2, 16 samples) after 20 steps on the small vase."""
    from conftest import small

    from mitnerf.train.checkpoint import save_checkpoint
    from mitnerf.train.fit import fit

    run = fit(vase_small, small("vanilla-3d", width=16, depth=2, n_coarse=16, n_fine=0, iters=20), "drjit")
    return save_checkpoint(run, tmp_path_factory.mktemp("ckpt") / "vase")


def test_a_trained_model_makes_a_video(tiny_checkpoint, tmp_path):
    from mitnerf.data.color import to_uint8
    from mitnerf.train.checkpoint import load_checkpoint

    run, _ = load_checkpoint(tiny_checkpoint)
    v = orbit_video(run.backend, OrbitConfig(n_frames=6, resolution=16), tmp_path, progress=False)
    assert set(v.paths) == {"color_gif", "color_mp4", "depth_gif", "depth_mp4"}
    for key, path in v.paths.items():
        assert read_video(path).shape == (6, 16, 16, 3), key
    gif = read_video(v.paths["color_gif"]).astype(float)
    assert np.abs(gif - to_uint8(v.frames.rgb)).mean() < 4        # the frames, in order (GIF palette error)
    assert re.fullmatch(r"video 6 frames 16x16 in \S+ s \(\S+ frames/s\)", v.summary())


def video_cli(argv):
    """The ``video`` sub-command on its own parser (errors propagate instead of exit status 2)."""
    from mitnerf.cli import Parser, video_cmd

    parser = Parser(prog="mitnerf")
    video_cmd.register(parser.add_subparsers(dest="command", required=True, parser_class=Parser))
    args = parser.parse_args(["video", *argv])
    return args.run(args)


def test_video_cli_writes_videos_mesh_and_chamfer(tiny_checkpoint, tmp_path, capsys):
    out = tmp_path / "video"
    assert video_cli(["--checkpoint", str(tiny_checkpoint), "--out", str(out), "--frames", "4", "--image-size", "12",
                      "--level", "auto", "--mesh-resolution", "20"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert re.fullmatch(r"video 4 frames 12x12 in \S+ s \(\S+ frames/s\)", lines[-1])
    # 20 steps leave no surface at density 3, the level mitnerf's Chamfer distance measures: said, not guessed
    assert any(line.startswith("no Chamfer distance: it measures the surface at density 3") for line in lines)
    for name in ("color.gif", "color.mp4", "depth.gif", "depth.mp4", "mesh.ply", "mesh.png"):
        assert (out / name).stat().st_size > 0, name
    assert not (out / "chamfer.json").exists()
    assert read_video(out / "color.mp4").shape == (4, 12, 12, 3)


def test_video_measures_the_chamfer_distance_fit_reports(tmp_path, capsys):
    """One definition: a ball of density 10 (radius 0.5) against its own mesh, by the video's writer and by the
    evaluation's metric, the same figure, far below the ball's size."""
    import json
    from types import SimpleNamespace

    import pyvista as pv

    from mitnerf.cli.video_cmd import write_mesh_outputs
    from mitnerf.geometry import field_chamfer

    truth = tmp_path / "ball.ply"
    pv.Sphere(radius=0.5, theta_resolution=96, phi_resolution=96).triangulate().save(str(truth))
    density = lambda x: np.where(np.linalg.norm(np.asarray(x), axis=-1) < 0.5, 10.0, 0.0).astype(np.float32)
    model = SimpleNamespace(backend=SimpleNamespace(density=density), bound=1.0, dataset_meta={"mesh": str(truth)})
    cfg = OrbitConfig()
    result = write_mesh_outputs(model, tmp_path, 3.0, 128, cfg, progress=False)
    assert result["chamfer"] == pytest.approx(field_chamfer(density, 1.0, truth).chamfer)
    assert result["chamfer"] < 0.02 and json.loads((tmp_path / "chamfer.json").read_text())["n_points"] == 100_000


def test_video_cli_errors_say_what_to_do(tiny_checkpoint, bunny_small, tmp_path):
    from conftest import small

    from mitnerf.train.checkpoint import save_checkpoint
    from mitnerf.train.fit import fit

    with pytest.raises(MitnerfError, match="not a mitnerf checkpoint.*mitnerf fit"):
        video_cli(["--checkpoint", str(tmp_path / "nothing"), "--out", str(tmp_path / "v")])
    with pytest.raises(MitnerfError, match="--level: it must be a density"):
        video_cli(["--checkpoint", str(tiny_checkpoint), "--out", str(tmp_path / "v"), "--level", "high"])
    # 20 steps leave densities near 0.3 everywhere: the default level 3 has no surface; nothing is written
    with pytest.raises(MitnerfError, match=r"nothing was written.*no surface at density level 3.*span \["):
        video_cli(["--checkpoint", str(tiny_checkpoint), "--out", str(tmp_path / "v"), "--frames", "2",
                   "--image-size", "8", "--mesh-resolution", "8"])
    assert not (tmp_path / "v").exists() and len(list(tmp_path.iterdir())) == 0
    run2d = fit(bunny_small, small(width=16, depth=2, n_coarse=16, iters=2, batch_rays=64), "drjit")
    save_checkpoint(run2d, tmp_path / "ckpt2d")
    with pytest.raises(MitnerfError, match="holds a 2D vanilla field; `mitnerf video`.*needs a 3D one"):
        video_cli(["--checkpoint", str(tmp_path / "ckpt2d"), "--out", str(tmp_path / "v2")])

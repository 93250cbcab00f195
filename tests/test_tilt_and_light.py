"""Cloth tilt from the texture's perspective, the light turned with it and refined, and the pinned plane of the geometry fit."""
from __future__ import annotations

import logging

import numpy as np
import pytest

from clothscope.core.config import settings
from clothscope.core.mesh import grid_faces
from clothscope.core.runtime import mitsuba_for
from clothscope.fit.geometry import grid_from, pinned_plane, starting_light, tilted_grid
from clothscope.fit.light import apply_light, cloth_normal, estimate_light, light_from_latent, thread_light, tilted
from clothscope.fit.loop import LoopSettings, optimise, render
from clothscope.fit.model import FitCamera, FitLight, FitScene, Material, build_scene, plane_grid
from clothscope.fit.target import Target, image_loss
from clothscope.fit.tilt import TiltEstimate, estimate_tilt

CAMERA = FitCamera(25.0)
LOG = logging.getLogger("test_tilt_and_light")


def photo_of_tilted_weave(slope_x: float, slope_y: float, period: float = 0.05, size: int = 256,
                          rotation_deg: float = 20.0) -> np.ndarray:
    """Linear RGB image of a plain-weave-like lattice on the plane z = slope_x x + slope_y y, through the fit camera.

    Each pixel's ray from (0, 0, distance) meets the plane; the texture is a
    function of the in-plane coordinates, so threads farther away look finer.
    """
    t = np.tan(np.deg2rad(CAMERA.fov_deg) / 2)
    s = (np.arange(size) + 0.5) / size * 2 - 1
    sx, sy = np.meshgrid(s, s)
    dx, dy = sx * t, -sy * t  # ray direction (dx, dy, -1): image columns along +x, rows along -y
    depth = CAMERA.distance / (1 + slope_x * dx + slope_y * dy)
    x, y = dx * depth, dy * depth
    u = x * np.sqrt(1 + slope_x**2)  # arc length on the plane (to first order)
    v = y * np.sqrt(1 + slope_y**2)
    a = np.deg2rad(rotation_deg)
    pa, pb = np.cos(a) * u + np.sin(a) * v, -np.sin(a) * u + np.cos(a) * v
    texture = 0.5 + 0.2 * np.cos(2 * np.pi * pa / period) + 0.15 * np.cos(2 * np.pi * pb / period)
    return texture[..., None] * np.array([0.6, 0.4, 0.3])


@pytest.mark.parametrize("slopes", [(0.0, 0.0), (0.12, 0.0), (0.0, -0.1), (-0.08, 0.09)])
def test_tilt_of_a_lattice_seen_in_perspective_is_recovered(slopes):
    image = photo_of_tilted_weave(*slopes)
    estimate = estimate_tilt(image, np.ones(image.shape[:2]), CAMERA, prior_deg=30.0)
    assert estimate.slope_x == pytest.approx(slopes[0], abs=0.02)
    assert estimate.slope_y == pytest.approx(slopes[1], abs=0.02)
    assert len(estimate.periods_px) == 2
    assert estimate.stderr_x < 0.02 and estimate.stderr_y < 0.02


def test_clipped_pixels_do_not_move_the_estimate():
    image = photo_of_tilted_weave(0.1, 0.05)
    weight = np.ones(image.shape[:2])
    weight[100:140, 60:200] = 0.0
    image[100:140, 60:200] = 1.0
    estimate = estimate_tilt(image, weight, CAMERA, prior_deg=30.0)
    assert estimate.slope_x == pytest.approx(0.1, abs=0.03)
    assert estimate.slope_y == pytest.approx(0.05, abs=0.03)


def test_almost_fully_clipped_photo_reads_level_without_error():
    image = photo_of_tilted_weave(0.1, 0.05)
    weight = np.zeros(image.shape[:2])
    weight[128, :] = 1.0  # one unclipped row cannot show a plane
    estimate = estimate_tilt(image, weight, CAMERA, prior_deg=5.0)
    assert np.isfinite(estimate.slope_x) and np.isfinite(estimate.slope_y) and estimate.degrees < 1.5


@pytest.mark.parametrize("case", ["noise", "flat", "black", "tiny"])
def test_textures_without_a_lattice_read_as_about_level(case):
    rng = np.random.default_rng(3)
    image = {
        "noise": 0.3 + 0.05 * rng.standard_normal((256, 256, 3)),
        "flat": np.full((256, 256, 3), 0.4),
        "black": np.zeros((256, 256, 3)),
        "tiny": 0.3 + 0.05 * rng.standard_normal((16, 16, 3)),
    }[case]
    estimate = estimate_tilt(image, np.ones(image.shape[:2]), CAMERA, prior_deg=5.0)
    assert np.isfinite(estimate.slope_x) and np.isfinite(estimate.slope_y)
    assert estimate.degrees < 1.5
    record = estimate.as_record()
    assert all(v is None or np.isfinite(v) for k, v in record.items() if k != "periods_px")


def test_prior_shrinks_uncertain_slopes_and_zero_prior_pins_level():
    sure, unsure = TiltEstimate(0.1, 0.1, 0.001, 1.0), TiltEstimate(0.1, 0.1, 1.0, 0.001)
    assert sure.shrunk(5.0).slope_x == pytest.approx(0.1, rel=1e-3)
    assert sure.shrunk(5.0).slope_y < 0.01
    assert unsure.shrunk(5.0).slope_x < 0.01
    image = photo_of_tilted_weave(0.12, 0.0)
    assert estimate_tilt(image, np.ones(image.shape[:2]), CAMERA, prior_deg=0.0) == TiltEstimate()


def test_light_turns_with_the_cloth_keeping_its_incidence():
    light = FitLight(30.0, 40.0, 3.0)
    assert tilted(light, 0.0, 0.0).polar_deg == pytest.approx(30.0)
    assert tilted(light, 0.0, 0.0).azimuth_deg == pytest.approx(40.0)
    turned = tilted(light, 0.15, -0.05)
    normal = np.array([-0.15, 0.05, 1.0]) / np.linalg.norm([-0.15, 0.05, 1.0])
    direction = np.array(turned.position) / turned.distance
    assert np.degrees(np.arccos(direction @ normal)) == pytest.approx(30.0, abs=1e-6)
    assert turned.intensity == pytest.approx(light.intensity)  # the exposure convention follows the cloth


@pytest.fixture(scope="module")
def mi():
    return mitsuba_for("llvm_ad_rgb", 2)


def test_geometry_pins_the_plane_it_starts_from(mi):
    grid = tilted_grid(plane_grid(CAMERA, 16, 0.06), TiltEstimate(0.1, -0.05, 0.01, 0.01))
    x, y = grid[..., 0], grid[..., 1]
    assert np.allclose(pinned_plane(grid, True).reshape(x.shape), 0.1 * x - 0.05 * y)
    assert np.allclose(pinned_plane(grid, False), 0.0)
    steps = mi.ad.LargeSteps(mi.Float(grid.ravel().astype(np.float32)), mi.UInt32(grid_faces(16).ravel()), 10.0)
    moved = grid.copy()
    moved[..., 2] += 0.3 + 0.2 * x + 0.05 * np.exp(-(x**2) / 0.02)  # offset, a new tilt and a fold
    u = np.array(steps.to_differential(mi.Float(moved.ravel().astype(np.float32))))
    out = grid_from(mi, steps, u, grid, True)
    fold_only = out[..., 2] - (0.1 * x - 0.05 * y)
    assert abs(fold_only.mean()) < 1e-5
    assert abs((fold_only * x).sum()) < 1e-4 and abs((fold_only * y).sum()) < 1e-4


def light_scene(mi, light: FitLight, resolution: int = 32):
    """A flat glossy sheet under ``light``, rendered with one bounce."""
    fit = FitScene(CAMERA, light, plane_grid(CAMERA, 16, 0.06), 0.06, Material((0.5, 0.4, 0.3), 0.5, 0.4))
    return build_scene(mi, fit, resolution, {"type": "direct"}, "independent")


def test_rendered_light_is_the_recorded_light(mi):
    light, normal = tilted(FitLight(25.0, 70.0, 3.0), 0.05, -0.08), cloth_normal(0.05, -0.08)
    params = mi.traverse(light_scene(mi, light))
    latent = mi.Float(np.array([0.3, -0.2], dtype=np.float32))
    apply_light(mi, params, light, latent, normal)
    recorded = light_from_latent(light, np.array([0.3, -0.2]), normal)
    assert np.allclose(np.array(params["light.position"]).ravel(), recorded.position, atol=1e-5)
    assert float(np.array(params["light.intensity.value"]).ravel()[0]) == pytest.approx(recorded.intensity, rel=1e-5)
    unchanged = light_from_latent(light, np.zeros(2), normal)
    assert unchanged.position == pytest.approx(light.position, abs=1e-9)
    assert unchanged.intensity == pytest.approx(light.intensity, rel=1e-9)


def test_light_direction_is_recovered_by_gradient_descent(mi):
    true, start = FitLight(30.0, 50.0, 3.0), FitLight(38.0, 75.0, 3.0)
    target = Target(np.array(mi.render(light_scene(mi, true), spp=64, seed=1), dtype=np.float32)[..., :3],
                    np.ones((32, 32), dtype=np.float32))
    scene = light_scene(mi, start)
    params = mi.traverse(scene)
    normal = cloth_normal(0.0, 0.0)

    def loss_fn(opt, it):
        apply_light(mi, params, start, opt["light"], normal)
        params.update()
        return image_loss(mi, render(mi, scene, params, 8, it), target)

    loop = optimise(mi, {"light": np.zeros(2, dtype=np.float32)}, loss_fn, LoopSettings(60, 0.05), LOG, "light")
    fitted = np.array(light_from_latent(start, loop.best["light"], normal).position) / 3.0
    angle = np.degrees(np.arccos(np.clip(fitted @ (np.array(true.position) / 3.0), -1, 1)))
    start_angle = np.degrees(np.arccos(np.array(start.position) @ np.array(true.position) / 9.0))
    assert angle < 2.0 < start_angle
    assert loop.best_loss < 0.1 * loop.curve[0]["loss"]


def photo_of_yarns_lit_from(azimuth_deg: float | None, size: int = 160, period: float = 10.0) -> np.ndarray:
    """A basket of round yarns (rows and columns of half-cylinders) shaded by a distant white light.

    ``azimuth_deg`` (image +x = 0, +y up) puts the light 45 degrees from the normal; None puts it at the lens.
    """
    rows, cols = np.mgrid[0:size, 0:size].astype(float)
    across = lambda t: np.sqrt(np.clip(1.0 - ((t % period) / period * 2.0 - 1.0) ** 2, 0.0, None))  # noqa: E731
    height = 0.35 * period * np.maximum(across(rows), across(cols))
    d_row, d_col = np.gradient(height)
    normal = np.stack([-d_col, d_row, np.ones_like(height)], axis=-1)  # +y is up, against the rows
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    if azimuth_deg is None:
        light = np.array([0.0, 0.0, 1.0])
    else:
        a = np.radians(azimuth_deg)
        light = np.array([np.cos(a), np.sin(a), 1.0]) / np.sqrt(2.0)
    shade = np.clip(normal @ light, 0.0, None)
    return np.repeat((0.1 + 0.6 * shade)[..., None], 3, axis=2).astype(np.float32)


@pytest.mark.parametrize("azimuth", [0.0, 70.0, 135.0, 250.0, 320.0])
def test_threads_tell_the_side_the_light_comes_from(azimuth):
    found, strength = thread_light(photo_of_yarns_lit_from(azimuth), np.ones((160, 160), dtype=np.float32))
    assert abs((found - azimuth + 180.0) % 360.0 - 180.0) < 20.0
    assert strength > 0.3


def test_a_light_at_the_lens_or_no_relief_shows_no_side():
    weight = np.ones((160, 160), dtype=np.float32)
    assert thread_light(photo_of_yarns_lit_from(None), weight)[1] < 0.05
    assert thread_light(np.full((160, 160, 3), 0.4, dtype=np.float32), weight) == (0.0, 0.0)
    assert thread_light(photo_of_yarns_lit_from(30.0), np.zeros((160, 160), dtype=np.float32)) == (0.0, 0.0)


def test_the_light_starts_where_the_chosen_evidence_puts_it():
    photo = Target(photo_of_yarns_lit_from(200.0, size=128), np.ones((128, 128), dtype=np.float32))
    falloff_only = settings("fit.geometry")
    light, record = starting_light(photo, CAMERA, falloff_only)
    assert record["chosen"] == "falloff" and "threads" not in record
    light, record = starting_light(photo, CAMERA, settings("fit.geometry", light_start="threads"))
    assert record["chosen"] == "threads"
    assert abs((light.azimuth_deg - 200.0 + 180.0) % 360.0 - 180.0) < 20.0
    assert light.polar_deg >= falloff_only.thread_light_polar_deg
    unsure = settings("fit.geometry", light_start="threads", thread_light_strength=10.0)
    assert starting_light(photo, CAMERA, unsure)[1]["chosen"] == "falloff"


def test_a_light_cannot_be_placed_on_a_clipped_photo():
    image = np.full((256, 256, 3), 0.4)
    with pytest.raises(ValueError, match="no unclipped pixel"):
        estimate_light(image, np.zeros((256, 256)), CAMERA)
    light, residual = estimate_light(image, np.ones((256, 256)), CAMERA)
    assert np.isfinite(residual) and 0.0 <= light.polar_deg <= 64.0

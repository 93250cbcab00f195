"""Inverse renderer: tiny end-to-end fits, hard cases that must stay finite, gradients, effects plan."""
from __future__ import annotations

import json
import logging
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import SYNTHETIC

from clothscope.core.config import settings as config_settings
from clothscope.core.imageio import linear_to_srgb, read_exr, write_png
from clothscope.core.runtime import mitsuba_for
from clothscope.fit import jobs
from clothscope.fit.effects import Evidence, geometry_evidence, plan_stage
from clothscope.fit.loop import LoopSettings, optimise, render_seed
from clothscope.fit.model import BSDF_KEYS, FitCamera, FitLight, FitScene, Material, build_scene, plane_grid
from clothscope.fit.normals import NormalSettings, cavity_factor_np, height_to_normals_np, initial_height, relief_prior
from clothscope.fit.target import Target, unexplained_share
from clothscope.prepare.image import prepare_image

LOG = logging.getLogger("test_fit")
TINY = dict(
    geometry=config_settings("fit.geometry", resolution=16, spp=4, iterations=6),
    material=config_settings("fit.material", resolution=32, spp=2, iterations=6),
    normals=config_settings("fit.normals", resolution=32, spp=2, texture=32, iterations=6, joint_iterations=6),
)


@pytest.fixture(scope="module")
def mi():
    return mitsuba_for("llvm_ad_rgb", 2)


def run_tiny_fit(photo_path, tmp_path, full_effects: bool = False, normals: NormalSettings | None = None,
                 min_detail: float | None = None) -> dict:
    """prepare -> geometry -> material -> normals on tiny settings; returns the final state.

    ``min_detail`` overrides prepare's texture gate (None keeps the schema default).
    """
    prepared, fit = tmp_path / "prepared", tmp_path / "fit"
    gate = {} if min_detail is None else {"min_detail": min_detail}
    prepare_image("case", photo_path, prepared, config_settings("prepare", working_resolution=64, scale="frame", **gate))
    common = dict(variant="llvm_ad_rgb", threads=2, full_effects=full_effects, log=LOG, sample_seed=0)
    jobs.geometry_job(str(prepared), str(fit / "geometry"), TINY["geometry"], **common)
    jobs.material_job(str(prepared), str(fit / "geometry"), str(fit / "material"), TINY["material"], **common)
    jobs.normals_job(str(prepared), str(fit / "material"), str(fit / "normals"), normals or TINY["normals"], **common)
    return json.loads((fit / "normals" / "state.json").read_text())


def assert_all_finite(state: dict, normals_dir) -> None:
    """Every number in the state and every texel of the maps is finite; normals are unit and face up."""
    text = json.dumps(state)
    assert "NaN" not in text and "Infinity" not in text
    normals = read_exr(normals_dir / "normal.exr")
    assert np.all(np.isfinite(normals))
    assert np.allclose(np.linalg.norm(normals, axis=-1), 1.0, atol=1e-3)
    assert normals[..., 2].min() > 0.0
    assert np.all(np.isfinite(read_exr(normals_dir / "height.exr")))
    m = state["material"]
    assert 0.05 <= m["roughness"] <= 1.0 and 0.0 <= m["specular"] <= 1.0
    assert all(0.0 <= c <= 1.0 for c in m["base_color"])


def render_case(mi, path, material: Material, light: FitLight, grid: np.ndarray | None = None, gain: float = 1.0) -> None:
    """Render a 64 px photo of the fit model itself and save it as an 8-bit sRGB PNG."""
    camera = FitCamera()
    fit = FitScene(camera, light, plane_grid(camera, 32, 0.06) if grid is None else grid, 0.06, material)
    image = np.array(mi.render(build_scene(mi, fit, 64, {"type": "direct"}, "independent"), spp=16, seed=1))[..., :3] * gain
    write_png(path, linear_to_srgb(np.clip(image, 0, 1)))


def folded_grid(amplitude: float) -> np.ndarray:
    grid = plane_grid(FitCamera(), 32, 0.06)
    grid[..., 2] = amplitude * np.sin(grid[..., 0] * 12.0)
    return grid


@pytest.mark.slow
def test_tiny_fit_of_a_synthetic_photo_writes_every_output(tmp_path):
    state = run_tiny_fit(SYNTHETIC / "canvas" / "canvas_red.png", tmp_path)
    assert state["status"] == "fitted"
    for stage in ("geometry", "material", "normals"):
        folder = tmp_path / "fit" / stage
        for name in ("loss.csv", "compare.png", "scene.xml", "mesh.ply", "state.json"):
            assert (folder / name).stat().st_size > 0, (stage, name)
    assert (tmp_path / "fit" / "material" / "material.json").exists()
    assert state["effects"][0]["integrator"] == "direct_unshadowed"
    assert state["psnr_db"] > 15.0 and 0.0 < state["unexplained_share"] < 1.0
    assert_all_finite(state, tmp_path / "fit" / "normals")
    geometry = json.loads((tmp_path / "fit" / "geometry" / "state.json").read_text())
    assert 0.0 <= geometry["tilt"]["degrees"] < 20.0 and len(geometry["tilt"]["periods_px"]) <= 2
    assert geometry["scene"]["light"]["incidence_deg"] is not None  # exposure kept against the cloth's mean normal


def test_normals_without_joint_pass_keep_the_material_stage_bsdf(tmp_path):
    settings = config_settings("fit.normals", resolution=32, spp=2, texture=32, iterations=4, joint_iterations=0)
    state = run_tiny_fit(SYNTHETIC / "satin" / "satin_red.png", tmp_path, normals=settings)
    material = json.loads((tmp_path / "fit" / "material" / "state.json").read_text())["material"]
    assert state["status"] == "fitted" and state["material"] == material
    assert len(state["stopped"]) == 1 and not state["warnings"]


def test_shade_texture_takes_the_holes_of_an_open_weave_and_stays_in_range(tmp_path):
    """albedo_weight > 0: shade.exr is written, finite, in (0, 1 / s0], darker over gauze holes than over yarn."""
    from clothscope.features.structure import StructureSettings, shade_features
    from clothscope.fit.normals import SHADE_LATENT0
    from clothscope.fit.outputs import SHADE_FILE

    settings = config_settings("fit.normals", resolution=64, spp=2, texture=64, iterations=12, joint_iterations=6, albedo_weight=0.05,
                              colour_model="one_colour")
    state = run_tiny_fit(SYNTHETIC / "cotton_gauze" / "cotton_gauze_ivory.png", tmp_path, normals=settings)
    assert state["status"] == "fitted"
    folder = tmp_path / "fit" / "normals"
    assert_all_finite(state, folder)
    shade = read_exr(folder / SHADE_FILE)[..., 0]
    assert shade.shape == (64, 64) and np.all(np.isfinite(shade))
    assert shade.min() > 0.0 and shade.max() <= 1.0 / (1.0 / (1.0 + math.exp(-SHADE_LATENT0))) + 1e-4
    assert np.percentile(shade, 10) < 0.95 < np.percentile(shade, 90)  # the holes (dark backdrop) were darkened
    # the exported scene loads and renders with its colour texture (albedo.exr = colour x shade)
    mi = mitsuba_for("llvm_ad_rgb", 2)
    rendered = np.array(mi.render(mi.load_file(str(folder / "scene.xml")), spp=16))[..., :3]
    albedo = read_exr(folder / "albedo.exr")
    assert albedo.shape == (64, 64, 3) and np.all(np.isfinite(rendered))
    assert np.allclose(albedo[..., 0], shade * state["material"]["base_color"][0], atol=1e-4)
    features = shade_features(shade.astype(np.float64), StructureSettings(0.1, 10.0, 0.3, "pixels"))
    assert all(math.isfinite(v) for v in features.values()) and any(v != 0.0 for v in features.values())
    # without a shade texture the shade columns are zero
    assert set(shade_features(None, StructureSettings(0.1, 10.0, 0.3, "pixels")).values()) == {0.0}


def render_stripes(mi, path: Path, blur: float = 0.0) -> None:
    """A flat cloth of navy and ecru stripes 8 px wide along the columns, their edges mixed over ``blur`` texels, to ``path``."""
    from scipy import ndimage

    from clothscope.fit.model import shaded_texture

    camera, material = FitCamera(), Material((0.5, 0.5, 0.5), 0.3, 0.7)
    fit = FitScene(camera, FitLight(15, 30), plane_grid(camera, 32, 0.06), 0.06, material)
    columns = np.arange(64)
    stripes = np.where((columns // 8) % 2 == 1, np.array([[1.3], [1.2], [0.9]]), np.array([[0.3], [0.4], [1.0]])).T
    if blur > 0:
        stripes = ndimage.gaussian_filter1d(stripes, blur, axis=0, mode="wrap")
    albedo = shaded_texture(material, np.ones((64, 64)), np.broadcast_to(stripes[None, :, :], (64, 64, 3)))
    scene = build_scene(mi, fit, 64, {"type": "direct"}, "independent", albedo_texture=albedo)
    image = np.array(mi.render(scene, spp=32, seed=1))
    write_png(path, linear_to_srgb(np.clip(image[..., :3], 0, 1)))


@pytest.mark.slow
def test_a_striped_flat_cloth_keeps_its_stripes_in_the_colour_and_out_of_the_relief(tmp_path, mi):
    """colour_model auto: a photo of two dyes gets the dye layout; it re-renders the photo and tilts the flat cloth's normals less."""
    render_stripes(mi, tmp_path / "striped.png")
    tilt, psnr = {}, {}
    for model in ("auto", "one_colour"):
        settings = config_settings("fit.normals", resolution=64, spp=2, texture=64, iterations=12, joint_iterations=6, colour_model=model)
        state = run_tiny_fit(tmp_path / "striped.png", tmp_path / model, normals=settings)
        folder = tmp_path / model / "fit" / "normals"
        assert_all_finite(state, folder)
        tilt[model] = float(np.degrees(np.arccos(read_exr(folder / "normal.exr")[..., 2])).mean())
        psnr[model] = state["psnr_db"]
        assert state["colour_model"]["kind"] == ("dye_layout" if model == "auto" else "one_colour")
        assert (folder / "albedo.exr").exists() == (model == "auto")
    assert state["colour_model"] == {"kind": "one_colour", "dye_groups": 1, "shares": [1.0]}
    assert psnr["auto"] > psnr["one_colour"] + 6.0  # one colour cannot render the stripes
    assert tilt["auto"] < 0.8 * tilt["one_colour"]  # ... and pushes them into the normals



@pytest.mark.slow
def test_a_blurred_dye_edge_is_colour_in_the_mixed_layout_not_tilt(tmp_path, mi):
    """layout_mixing mixed: where defocus mixed two dyes, the layout takes the mixture and the flat cloth stays flatter."""
    render_stripes(mi, tmp_path / "blurred.png", blur=2.0)
    prepared, folder = tmp_path / "prepared", tmp_path / "fit"
    prepare_image("case", tmp_path / "blurred.png", prepared, config_settings("prepare", working_resolution=64, scale="frame"))
    common = dict(variant="llvm_ad_rgb", threads=2, full_effects=False, log=LOG, sample_seed=0)
    jobs.geometry_job(str(prepared), str(folder / "geometry"), TINY["geometry"], **common)
    jobs.material_job(str(prepared), str(folder / "geometry"), str(folder / "material"), TINY["material"], **common)
    tilt, psnr = {}, {}
    for mixing in ("hard", "mixed"):
        settings = config_settings("fit.normals", resolution=64, spp=2, texture=64, iterations=12, joint_iterations=6,
                                   colour_model="dye_layout", layout_mixing=mixing)
        out = folder / f"normals_{mixing}"
        jobs.normals_job(str(prepared), str(folder / "material"), str(out), settings, **common)
        state = json.loads((out / "state.json").read_text())
        assert_all_finite(state, out)
        assert state["colour_model"]["mixing"] == mixing
        across = read_exr(out / "normal.exr")[..., 0].mean(axis=0)  # tilt across the stripes, the noise averaged out
        tilt[mixing] = float(np.sqrt(np.mean(across**2)))
        psnr[mixing] = state["psnr_db"]
    assert psnr["mixed"] > psnr["hard"] + 0.3  # the mixed edges re-render the photo better ...
    assert tilt["mixed"] < 0.95 * tilt["hard"]  # ... and leave less of them to the relief


HARD_CASES = {
    "black_cloth": dict(material=Material((0.004, 0.004, 0.005), 0.5, 0.6), light=FitLight(20, 40)),
    "saturated_white": dict(material=Material((0.95, 0.95, 0.95), 1.0, 0.15), light=FitLight(10, 0), gain=1.0),
    "grazing_light": dict(material=Material((0.5, 0.3, 0.2), 0.5, 0.5), light=FitLight(82, 120)),
    "near_mirror": dict(material=Material((0.2, 0.2, 0.6), 1.0, 0.01), light=FitLight(5, 0)),
    "deep_folds": dict(material=Material((0.6, 0.6, 0.5), 0.5, 0.6), light=FitLight(30, 90), grid=folded_grid(0.35)),
}


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(HARD_CASES) + ["textureless"])
def test_hard_cases_stay_finite(mi, tmp_path, case):
    photo = tmp_path / f"{case}.png"
    if case == "textureless":
        write_png(photo, np.full((64, 64, 3), 0.5))
    else:
        render_case(mi, photo, **HARD_CASES[case])
    state = run_tiny_fit(photo, tmp_path, min_detail=0.0)  # the fit itself must stay finite where prepare's gate is off
    assert state["status"] == "fitted", state.get("reason")
    if case == "saturated_white":  # some pixels clipped and masked, not all
        clipped = json.loads((tmp_path / "prepared" / "status.json").read_text())["clipped_fraction"]
        assert 0.0 < clipped < 0.5
    assert_all_finite(state, tmp_path / "fit" / "normals")
    prior, knobs = state["relief_prior"], state["settings"]  # the fitted light decides the prior, and the state says so
    assert prior["near_camera"] == (state["scene"]["light"]["polar_deg"] < knobs["near_camera_deg"])
    near_weight = max(knobs["smoothness"], knobs["near_camera_smoothness"])
    assert prior["smoothness"] == (near_weight if prior["near_camera"] else knobs["smoothness"])


@pytest.mark.parametrize("polar, smoothness, near_weight, expected", [
    (5.0, 0.0, 0.001, 0.001),  # a flash or ring light: the prior
    (9.9, 0.0, 0.001, 0.001),
    (10.0, 0.0, 0.001, 0.0),  # at the threshold and beyond: the configured smoothness
    (30.0, 0.0, 0.001, 0.0),
    (5.0, 0.01, 0.001, 0.01),  # a larger configured weight is kept
    (5.0, 0.0, 0.0, 0.0),  # near_camera_smoothness 0 switches it off
])
def test_relief_prior_only_under_a_light_near_the_camera(polar, smoothness, near_weight, expected):
    settings = replace(TINY["normals"], smoothness=smoothness, near_camera_deg=10.0, near_camera_smoothness=near_weight)
    fitted_with, record = relief_prior(settings, FitLight(polar, 120.0))
    assert fitted_with.smoothness == expected == record["smoothness"]
    assert record["near_camera"] == (polar < 10.0) and record["light_from_camera_deg"] == polar
    assert replace(fitted_with, smoothness=settings.smoothness) == settings  # nothing else changes


def test_unexplained_share_is_zero_for_the_photo_one_for_its_mean_and_ignores_colour_gain_and_clipped_pixels():
    rng = np.random.default_rng(3)
    photo = rng.uniform(0.1, 0.6, (16, 16, 3)).astype(np.float32)
    weight = np.ones((16, 16), np.float32)
    target = Target(photo, weight)
    assert unexplained_share(photo, target) == 0.0
    assert unexplained_share(np.broadcast_to(photo.mean(axis=(0, 1)), photo.shape), target) == pytest.approx(1.0)
    fit = photo + rng.normal(0.0, 0.05, photo.shape).astype(np.float32)
    gain = np.array([0.5, 1.0, 2.0], np.float32)
    assert unexplained_share(fit * gain, Target(photo * gain, weight)) == pytest.approx(
        unexplained_share(fit, target), rel=0.3)  # channels weigh by their own contrast, so only near, not equal
    assert unexplained_share(fit * 3.0, Target(photo * 3.0, weight)) == pytest.approx(unexplained_share(fit, target))
    clipped = weight.copy()
    clipped[:4] = 0.0
    spoiled = fit.copy()
    spoiled[:4] = 100.0  # a blown-out band the fit cannot and need not explain
    assert unexplained_share(spoiled, Target(photo, clipped)) == pytest.approx(
        unexplained_share(fit[4:], Target(photo[4:], weight[4:])))
    flat = np.full((8, 8, 3), 0.5, np.float32)
    assert math.isfinite(unexplained_share(flat + 0.1, Target(flat, np.ones((8, 8), np.float32))))


def test_rejected_image_is_skipped_by_every_stage(tmp_path):
    bad = tmp_path / "bad.png"
    bad.write_text("not an image")
    state = run_tiny_fit(bad, tmp_path)
    assert state["status"] == "skipped"
    assert "rejected by prepare" in state["reason"]


def test_gradients_match_finite_differences(mi):
    """AD derivative of the rendered image w.r.t. roughness and specular equals central differences."""
    import drjit as dr

    camera = FitCamera()
    fit = FitScene(camera, FitLight(25, 60), plane_grid(camera, 8, 0.06), 0.06, Material((0.4, 0.3, 0.2), 0.5, 0.4))
    scene = build_scene(mi, fit, 16, {"type": "direct"}, "independent")
    params = mi.traverse(scene)

    def mean_pixel(key: str, value) -> object:
        params[BSDF_KEYS[key]] = value
        params.update()
        return dr.mean(mi.render(scene, params, spp=256, seed=3, seed_grad=4).array)

    for key, x0 in (("roughness", 0.4), ("specular", 0.5)):
        x = mi.Float(x0)
        dr.enable_grad(x)
        value = mean_pixel(key, x)
        dr.backward(value)
        ad = float(dr.grad(x)[0])
        h = 1e-2
        fd = (float(mean_pixel(key, mi.Float(x0 + h))[0]) - float(mean_pixel(key, mi.Float(x0 - h))[0])) / (2 * h)
        assert math.isfinite(ad) and abs(ad - fd) <= 0.05 * abs(fd) + 1e-5, (key, ad, fd)
        params[BSDF_KEYS[key]] = mi.Float(x0)


def test_loss_image_and_gradient_pass_take_their_own_sample_counts(mi):
    """``render``: the image has ``spp`` samples per pixel, the gradient pass ``spp_grad`` (same expectation)."""
    import drjit as dr

    from clothscope.fit.loop import render

    camera = FitCamera()
    fit = FitScene(camera, FitLight(25, 60), plane_grid(camera, 8, 0.06), 0.06, Material((0.4, 0.3, 0.2), 0.5, 0.4))
    scene = build_scene(mi, fit, 16, {"type": "direct"}, "independent")
    params = mi.traverse(scene)
    reference = np.array(mi.render(scene, spp=8, seed=5))

    def image_and_gradient(spp_grad: int) -> tuple[np.ndarray, float]:
        x = mi.Float(0.4)
        dr.enable_grad(x)
        params[BSDF_KEYS["roughness"]] = x
        params.update()
        image = render(mi, scene, params, 8, 5, spp_grad)
        dr.backward(dr.mean(image.array))
        return np.array(image), float(dr.grad(x)[0])

    (image_2, grad_2), (image_64, grad_64) = image_and_gradient(2), image_and_gradient(64)
    assert np.array_equal(image_2, reference) and np.array_equal(image_64, reference)
    assert math.isfinite(grad_2) and grad_2 != grad_64  # a separate pass with its own sample count
    assert abs(grad_2 - grad_64) <= 0.2 * abs(grad_64)


def test_loop_restarts_on_non_finite_loss_and_keeps_best(mi):
    """A loss that turns NaN makes the loop restore the best values, halve the step and warn."""
    import drjit as dr

    def loss_fn(opt, it):
        x = opt["x"]
        loss = dr.sum((x - 3.0) ** 2)
        return loss * (float("nan") if it == 5 else 1.0)

    result = optimise(mi, {"x": np.zeros(2, np.float32)}, loss_fn, LoopSettings(40, 0.3), LOG, "toy")
    assert result.warnings and "restarting" in result.warnings[0]
    assert np.all(np.isfinite(result.best["x"])) and math.isfinite(result.best_loss)
    assert result.best_loss < 18.0  # improved on the start (x = 0: loss 18)


def test_keep_last_returns_the_final_iterate_not_a_lucky_noisy_loss(mi):
    """A loss value carrying a term its gradient lacks (a render's variance) biases "best"; "last" follows the gradient."""
    import drjit as dr

    def loss_fn(opt, it):  # value (x - 3)^2 + 2x, gradient that of (x - 3)^2 only
        return dr.sum((opt["x"] - 3.0) ** 2) + 2.0 * dr.detach(dr.sum(opt["x"]))

    best = optimise(mi, {"x": np.zeros(1, np.float32)}, loss_fn, LoopSettings(150, 0.1), LOG, "best")
    last = optimise(mi, {"x": np.zeros(1, np.float32)}, loss_fn, LoopSettings(150, 0.1, keep="last"), LOG, "last")
    assert abs(float(best.best["x"][0]) - 2.0) < 0.2  # the value's minimum, not the gradient's
    assert abs(float(last.best["x"][0]) - 3.0) < 0.1 and math.isfinite(last.best_loss)
    with pytest.raises(ValueError, match="keep"):
        LoopSettings(10, 0.1, keep="median")


def test_plateau_rule_stops_early(mi):
    import drjit as dr

    result = optimise(mi, {"x": np.zeros(1, np.float32)}, lambda opt, it: dr.sum(opt["x"] * 0.0 + 1.0),
                      LoopSettings(100, 0.1, patience=5), LOG, "flat")
    assert result.stopped.startswith("plateau") and len(result.curve) <= 7


def test_render_seeds_of_different_fit_seeds_never_meet():
    """Primal and gradient seeds (100 003 above) of fit.sample_seed 0..3 over the schema's 5000 iterations are all distinct."""
    seeds = [render_seed(seed, it) + offset for seed in range(4) for it in range(5000) for offset in (0, 100_003)]
    assert len(set(seeds)) == len(seeds)
    assert render_seed(0, 7) == 7  # 0 draws the samples of runs made before fit.sample_seed existed


def test_fit_seed_refits_with_other_samples_and_is_recorded(tmp_path):
    """The same fit.sample_seed gives the same fit; another one gives a different, finite fit; the state records it."""
    prepared = tmp_path / "prepared"
    prepare_image("case", SYNTHETIC / "canvas" / "canvas_red.png", prepared,
                  config_settings("prepare", working_resolution=64, scale="frame"))
    grids = {}
    for name, seed in (("first", 0), ("again", 0), ("other", 1)):
        jobs.geometry_job(str(prepared), str(tmp_path / name), TINY["geometry"], variant="llvm_ad_rgb", threads=1,
                          full_effects=False, log=LOG, sample_seed=seed)
        assert json.loads((tmp_path / name / "state.json").read_text())["sample_seed"] == seed
        grids[name] = np.load(tmp_path / name / "grid.npy")
    assert np.array_equal(grids["first"], grids["again"])
    assert not np.array_equal(grids["first"], grids["other"]) and np.all(np.isfinite(grids["other"]))


def test_effects_plan_simulates_only_what_the_scene_needs():
    camera, light = FitCamera(), FitLight(30.0, 45.0)
    flat = geometry_evidence(plane_grid(camera, 16, 0.06), camera, light)
    assert flat == Evidence(False, False, False, False)
    assert plan_stage("geometry", flat).integrator == "direct_unshadowed"
    assert plan_stage("normals", flat).integrator == "direct_unshadowed"
    assert geometry_evidence(plane_grid(camera, 16, 0.06), camera).cast_shadows  # unknown light: assume shadows
    deep = geometry_evidence(folded_grid(0.35), camera, light)
    assert deep.facing_folds
    assert plan_stage("material", deep).integrator == "prb" and plan_stage("material", deep).max_depth == 3
    shadowed = geometry_evidence(folded_grid(0.05), camera, FitLight(82.0, 0.0))
    assert shadowed.cast_shadows and not shadowed.facing_folds
    assert plan_stage("normals", shadowed).integrator == "direct"
    assert not geometry_evidence(folded_grid(0.05), camera, FitLight(20.0, 0.0)).cast_shadows
    occluded = Evidence(self_occlusion=True, cast_shadows=True)
    assert plan_stage("geometry", occluded).integrator == "direct_projective"
    assert plan_stage("normals", occluded).integrator == "direct"  # geometry fixed: no visibility gradients
    full = plan_stage("normals", flat, full_effects=True)
    assert full.integrator == "prb_projective" and full.max_depth >= 8
    for plan in (plan_stage("geometry", flat), full):
        assert not plan.spectral and not plan.polarized


def render_with_gradient(mi, fit: FitScene, integrator: dict) -> tuple[np.ndarray, float]:
    """64 px render of ``fit`` and the derivative of its mean with respect to roughness."""
    import drjit as dr

    scene = build_scene(mi, fit, 64, integrator, "independent")
    params = mi.traverse(scene)
    roughness = mi.Float(0.4)
    dr.enable_grad(roughness)
    params[BSDF_KEYS["roughness"]] = roughness
    params.update()
    image = mi.render(scene, params, spp=16, seed=3, seed_grad=4)
    dr.backward(dr.mean(image, axis=None))
    return np.array(image), float(dr.grad(roughness)[0])


@pytest.mark.parametrize("amplitude, polar", [(0.0, 30.0), (0.05, 20.0)])
def test_unshadowed_integrator_matches_direct_where_nothing_casts_shadows(mi, amplitude, polar):
    camera, light = FitCamera(), FitLight(polar, 60.0)
    fit = FitScene(camera, light, folded_grid(amplitude), 0.06, Material((0.6, 0.3, 0.2), 0.5, 0.4))
    assert not geometry_evidence(fit.grid, camera, light).cast_shadows
    direct, d_direct = render_with_gradient(mi, fit, {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0})
    unshadowed, d_unshadowed = render_with_gradient(mi, fit, {"type": "direct_unshadowed"})
    assert np.abs(direct - unshadowed).max() < 1e-4 * max(1.0, float(direct.max()))
    assert d_unshadowed == pytest.approx(d_direct, rel=1e-3)


def test_shadows_are_missing_only_from_the_unshadowed_integrator(mi):
    camera, light = FitCamera(), FitLight(82.0, 0.0)
    fit = FitScene(camera, light, folded_grid(0.05), 0.06, Material((0.6, 0.6, 0.6), 0.5, 0.6))
    assert geometry_evidence(fit.grid, camera, light).cast_shadows
    direct, _ = render_with_gradient(mi, fit, {"type": "direct"})
    unshadowed, _ = render_with_gradient(mi, fit, {"type": "direct_unshadowed"})
    assert unshadowed.mean() > 1.05 * direct.mean()


def height_gradient(mi, fit: FitScene, height: np.ndarray, target: np.ndarray, scene=None) -> np.ndarray:
    """Derivative of the squared error between a 32 px render of ``fit`` (or of ``scene``) with relief ``height`` and ``target``."""
    import drjit as dr

    from clothscope.fit.normals import neighbour_indices, normal_texture

    size = height.shape[0]
    scene = scene or build_scene(mi, fit, 32, {"type": "direct_unshadowed"}, "independent")
    params = mi.traverse(scene)
    latent = mi.Float(height.ravel())
    dr.enable_grad(latent)
    neighbours = {k: mi.UInt32(v) for k, v in neighbour_indices(size).items()}
    params[BSDF_KEYS["normalmap"]] = normal_texture(mi, latent, neighbours, size)
    params.update()
    image = mi.render(scene, params, spp=4, seed=3, seed_grad=4)
    dr.backward(dr.mean(dr.square(image - mi.TensorXf(target)), axis=None))
    return np.array(dr.grad(latent))


def test_unshadowed_backward_pass_gives_mitsubas_gradient_without_rendering_the_image_first(mi, monkeypatch):
    from clothscope.fit import integrator

    rng = np.random.default_rng(0)
    fit = FitScene(FitCamera(), FitLight(35.0, 60.0), folded_grid(0.03), 0.06, Material((0.6, 0.3, 0.2), 0.5, 0.3))
    height = rng.normal(scale=0.5, size=(16, 16)).astype(np.float32)
    target = rng.uniform(0.0, 0.3, size=(32, 32, 3)).astype(np.float32)
    direct = height_gradient(mi, fit, height, target)
    monkeypatch.setattr(integrator, "splats_one_pixel_per_sample", lambda film: False)  # Mitsuba's render_backward
    through_the_film = height_gradient(mi, fit, height, target)
    assert np.all(np.isfinite(direct)) and np.abs(through_the_film).max() > 0
    assert np.allclose(direct, through_the_film, rtol=1e-4, atol=1e-6 * np.abs(through_the_film).max())


def test_kept_intersections_give_the_same_render_and_gradient_and_stay_within_the_cache(mi):
    """A second render with the same seeds reuses the intersections: same image and gradient as a fresh integrator."""
    rng = np.random.default_rng(1)
    fit = FitScene(FitCamera(), FitLight(35.0, 60.0), folded_grid(0.03), 0.06, Material((0.6, 0.3, 0.2), 0.5, 0.3))
    height = rng.normal(scale=0.5, size=(16, 16)).astype(np.float32)
    target = rng.uniform(0.0, 0.3, size=(32, 32, 3)).astype(np.float32)
    fresh = build_scene(mi, fit, 32, {"type": "direct_unshadowed"}, "independent")
    kept = build_scene(mi, fit, 32, {"type": "direct_unshadowed", "intersection_cache": 2}, "independent")
    expected = height_gradient(mi, fit, height, target, fresh)
    first = height_gradient(mi, fit, height, target, kept)
    assert len(kept.integrator().cache) == 2  # the primal and the gradient pass of seeds 3 and 4
    again = height_gradient(mi, fit, height, target, kept)  # from the kept intersections
    assert np.array_equal(again, first) and np.abs(expected).max() > 0
    assert np.allclose(first, expected, rtol=1e-5, atol=1e-6 * np.abs(expected).max())
    image = np.array(mi.render(kept, spp=4, seed=9))
    assert len(kept.integrator().cache) == 2  # the oldest pass made room for seed 9
    assert np.allclose(image, np.array(mi.render(fresh, spp=4, seed=9)), rtol=1e-5, atol=1e-7)


def test_seed_cycle_repeats_the_render_seeds_and_keeps_only_our_integrators_intersections(mi):
    import drjit as dr

    from clothscope.fit.normals import stage_integrator

    seeds = []

    def loss(opt, seed):
        seeds.append(seed)
        return dr.sum(dr.square(opt["x"] - 1.0))

    flat = geometry_evidence(plane_grid(FitCamera(), 16, 0.06), FitCamera(), FitLight(30.0, 45.0))
    shadowed = Evidence(cast_shadows=True)
    assert stage_integrator(plan_stage("normals", flat), 16) == {"type": "direct_unshadowed", "intersection_cache": 32}
    assert stage_integrator(plan_stage("normals", flat), 0) == {"type": "direct_unshadowed"}
    assert "intersection_cache" not in stage_integrator(plan_stage("normals", shadowed), 16)  # Mitsuba's direct
    optimise(mi, {"x": np.zeros(1, np.float32)}, loss, LoopSettings(7, 0.1, sample_seed=2, seed_cycle=3), LOG, "cycle")
    assert seeds == [render_seed(2, it % 3) for it in range(7)]
    with pytest.raises(ValueError, match="seed_cycle"):
        LoopSettings(7, 0.1, seed_cycle=-1)


def test_only_a_box_filter_without_border_samples_takes_the_direct_backward_pass(mi):
    from clothscope.fit.integrator import splats_one_pixel_per_sample

    film = lambda rfilter, border: mi.load_dict({"type": "hdrfilm", "width": 8, "height": 8,  # noqa: E731
                                                 "rfilter": {"type": rfilter}, "sample_border": border})
    assert splats_one_pixel_per_sample(film("box", False))
    assert not splats_one_pixel_per_sample(film("box", True))
    assert not splats_one_pixel_per_sample(film("gaussian", False))


def render_noise(mi, scene, spp: int) -> float:
    """Root mean square noise of one render at ``spp``, from two renders with different seeds."""
    a, b = (np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64) for seed in (11, 12))
    return float(np.sqrt(np.mean((a - b) ** 2) / 2.0))


def test_fit_renders_stratify_the_pixel_and_stay_unbiased(mi):
    """The fit's sampler leaves less noise than independent samples at the same count, around the same image."""
    camera = FitCamera()
    fit = FitScene(camera, FitLight(30, 45), plane_grid(camera, 8, 0.06), 0.06, Material((0.5, 0.4, 0.3), 0.5, 0.3))
    u = np.arange(64) * 2 * np.pi / 16
    texture = height_to_normals_np(np.add.outer(np.sin(u), np.cos(u)).astype(np.float64)) * 0.5 + 0.5
    ours, independent = (build_scene(mi, fit, 32, {"type": "direct"}, kind, normal_texture=texture.astype(np.float32))
                         for kind in (config_settings("fit.normals").sampler, "independent"))
    assert render_noise(mi, ours, 16) < 0.5 * render_noise(mi, independent, 16)
    converged = [np.array(mi.render(scene, spp=256, seed=3)) for scene in (ours, independent)]
    assert np.abs(converged[0] - converged[1]).mean() < 0.02 * converged[1].mean()


def test_height_derived_normals_are_never_flipped_or_in_plane():
    rng = np.random.default_rng(0)
    for scale in (0.0, 1.0, 1e3, 1e6):
        normals = height_to_normals_np(rng.normal(size=(16, 16)) * scale)
        assert np.all(np.isfinite(normals)) and normals[..., 2].min() > 0.0


def test_shading_start_is_bright_high_dark_low_at_the_asked_slope():
    """initial_height: yarn crowns (bright) start high, gaps (dark) low, at the asked RMS slope; finite."""
    rows, cols = np.mgrid[0:64, 0:64]
    crowns = 0.5 + 0.3 * np.sin(2 * np.pi * cols / 8.0)  # stripes of period 8 px
    photo = np.repeat(crowns[..., None], 3, axis=2) * np.array([0.8, 0.3, 0.2])  # one dye
    height = initial_height(photo, 64, 0.0, 0.3).reshape(64, 64)
    assert np.all(np.isfinite(height))
    inner = height[8:-8, 8:-8]
    assert np.corrcoef(inner.ravel(), crowns[8:-8, 8:-8].ravel())[0, 1] > 0.95
    gy, gx = np.gradient(height)
    assert math.isclose(float(np.sqrt(np.mean(gx**2 + gy**2))), 0.3, rel_tol=1e-3)


@pytest.mark.parametrize("photo", [np.zeros((32, 32, 3)), np.full((32, 32, 3), 0.4)], ids=["black", "uniform"])
def test_shading_start_of_a_photo_without_contrast_is_flat(photo):
    height = initial_height(photo, 48, 0.06, 0.3)
    assert height.shape == (48 * 48,) and np.all(height == 0.0)


@pytest.mark.parametrize("pin_tilt", [True, False])
def test_pinned_depth_removes_mean_and_tilt_alike_in_numpy_and_drjit(mi, pin_tilt):
    import drjit as dr

    from clothscope.fit.geometry import pinned_depth, tilt_slopes

    grid = plane_grid(FitCamera(25.0), 16, 0.06)
    x, y = grid[..., 0].ravel(), grid[..., 1].ravel()
    fold = 0.05 * np.exp(-((x - 0.2) ** 2) / 0.02)
    z = 0.3 + 0.2 * x - 0.1 * y + fold
    slopes = tilt_slopes(grid, pin_tilt)
    pinned = pinned_depth(z, x, y, slopes, np.sum)
    assert abs(pinned.mean()) < 1e-12
    if pin_tilt:
        assert max(abs(pinned @ x), abs(pinned @ y)) < 1e-10
        assert np.ptp(pinned - fold) < 0.05  # the fold stays; only its own small plane part goes with the tilt
    else:
        assert np.allclose(pinned, z - z.mean())
    in_drjit = pinned_depth(mi.Float(z), mi.Float(x), mi.Float(y), slopes, dr.sum)
    assert np.allclose(np.array(in_drjit), pinned, atol=1e-5)


def test_curvature_is_the_four_neighbour_laplacian(mi):
    """curvature(h) of h = x^2 + y^2 (texel units) is 4 inside the map; a flat map has none."""
    from clothscope.fit.normals import curvature, neighbour_indices

    size = 8
    neighbours = {k: mi.UInt32(v) for k, v in neighbour_indices(size).items()}
    rows, cols = np.meshgrid(np.arange(size, dtype=float), np.arange(size, dtype=float), indexing="ij")
    lap = np.array(curvature(mi, mi.Float((rows**2 + cols**2).ravel()), neighbours)).reshape(size, size)
    assert np.allclose(lap[1:-1, 1:-1], 4.0)
    assert np.allclose(np.array(curvature(mi, mi.Float(np.full(size * size, 3.0)), neighbours)), 0.0)


def fitted_relief_curvature(normals_dir) -> float:
    """Mean squared 4-neighbour Laplacian of a fit's ``height.exr`` (texel units, edges clamped)."""
    height = read_exr(normals_dir / "height.exr")
    height = height[..., 0] if height.ndim == 3 else height
    padded = np.pad(height, 1, mode="edge")
    lap = padded[1:-1, 2:] + padded[1:-1, :-2] + padded[2:, 1:-1] + padded[:-2, 1:-1] - 4 * height
    return float(np.mean(lap**2))


def tiny_relief_fit(case_dir, **normals) -> tuple[dict, Path]:
    """A tiny fit of ``canvas_red`` (12 height-map iterations, no joint phase unless overridden) with these
    ``fit.normals`` settings, checked fitted and finite; returns the state and the normals folder."""
    tiny = dict(resolution=64, spp=2, texture=64, iterations=12, joint_iterations=0)
    state = run_tiny_fit(SYNTHETIC / "canvas" / "canvas_red.png", case_dir, normals=config_settings("fit.normals", **(tiny | normals)))
    folder = case_dir / "fit" / "normals"
    assert state["status"] == "fitted"
    assert_all_finite(state, folder)
    return state, folder


def test_smoothness_prior_lowers_the_fitted_relief_curvature(tmp_path):
    """smoothness > 0: the same tiny fit ends with a height map of lower mean squared Laplacian, and stays finite."""
    curvatures = {weight: fitted_relief_curvature(tiny_relief_fit(tmp_path / str(weight), smoothness=weight)[1])
                  for weight in (0.0, 0.01)}
    assert curvatures[0.01] < 0.5 * curvatures[0.0]


def test_repeat_prior_makes_the_fitted_relief_repeat_with_the_photo(tmp_path):
    """repeat_weight > 0: state.json records the photo's translations, and the same tiny fit ends with a height map
    that differs less from itself one repeat away (the prior's own measure), finite everywhere."""
    from clothscope.fit.repeat import repeat_penalty_np, shifted_samples

    fits = {weight: tiny_relief_fit(tmp_path / str(weight), repeat_weight=weight) for weight in (0.0, 1.0)}
    record = fits[1.0][0]["repeat_prior"]
    assert record["weight"] == 1.0 and 1 <= len(record["repeats"]) <= 2 and fits[0.0][0]["repeat_prior"]["weight"] == 0.0
    texels_per_pixel = fits[1.0][0]["texels_per_pixel"]
    samples = [shifted_samples(64, tuple(v * texels_per_pixel for v in r["shift_px"]), r["correlation"]) for r in record["repeats"]]
    penalty = {}
    for weight, (_, folder) in fits.items():
        height = read_exr(folder / "height.exr")[..., 0]
        penalty[weight] = repeat_penalty_np(height - height.mean(), samples) / max(float(np.var(height)), 1e-12)
    assert penalty[1.0] < 0.7 * penalty[0.0]


def test_a_light_near_the_camera_fits_with_the_near_camera_prior(tmp_path):
    """Under the rule (every fitted light counts as near at 90 degrees) the fit is the one configured smoothness gives."""
    ruled, ruled_dir = tiny_relief_fit(tmp_path / "rule", near_camera_deg=90.0, near_camera_smoothness=0.01)
    plain, plain_dir = tiny_relief_fit(tmp_path / "plain", smoothness=0.01)
    assert ruled["relief_prior"]["near_camera"] and ruled["relief_prior"]["smoothness"] == 0.01
    assert ruled["settings"]["smoothness"] == 0.0  # the configured knobs are recorded as configured
    # the same fit up to the last digits of two-thread reductions (the prior alone moves the relief far more)
    assert np.allclose(read_exr(ruled_dir / "height.exr"), read_exr(plain_dir / "height.exr"), atol=1e-4)
    far, far_dir = tiny_relief_fit(tmp_path / "far", near_camera_deg=0.0, near_camera_smoothness=0.01)
    assert not far["relief_prior"]["near_camera"] and far["relief_prior"]["smoothness"] == 0.0
    assert np.abs(read_exr(far_dir / "height.exr") - read_exr(plain_dir / "height.exr")).max() > 1e-2


def test_shading_start_puts_the_photo_pattern_into_the_height_map_the_fit_starts_from(tmp_path):
    """initial_relief = shading: with no iterations the fitted relief is the start, the photo's high-passed shading."""
    reliefs = {}
    for start in ("flat", "shading"):
        state, folder = tiny_relief_fit(tmp_path / start, iterations=0, initial_relief=start)
        assert state["settings"]["initial_relief"] == start
        reliefs[start] = read_exr(folder / "height.exr")[..., 0]
    assert np.all(reliefs["flat"] == 0.0)
    target = read_exr(tmp_path / "shading" / "prepared" / "image.exr")[..., :3]
    expected = initial_height(target, 64, 0.06, 0.3).reshape(64, 64)
    assert np.allclose(reliefs["shading"], expected, atol=1e-5)
    assert reliefs["shading"].std() > 0.1


def test_large_steps_solve_is_the_inverse_of_i_plus_lambda_laplacian_and_its_own_adjoint(mi):
    """HeightSteps: (I + lambda L) of a small grid matches the explicit 4-neighbour matrix; the Dr.Jit solve's
    gradient is the same solve of the output gradient (a symmetric matrix)."""
    import drjit as dr

    from clothscope.fit.large_steps import HeightSteps

    size, lambda_ = 5, 2.0
    steps = HeightSteps(size, lambda_)
    laplacian = np.zeros((size * size, size * size))
    for r in range(size):
        for c in range(size):
            for rr, cc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
                if 0 <= rr < size and 0 <= cc < size:
                    laplacian[r * size + c, r * size + c] += 1
                    laplacian[r * size + c, rr * size + cc] -= 1
    system = np.stack([steps.to_differential(row) for row in np.eye(size * size)])
    assert np.allclose(system, np.eye(size * size) + lambda_ * laplacian)
    rng = np.random.default_rng(3)
    height = rng.normal(size=size * size)
    assert np.allclose(steps.solve(steps.to_differential(height)), height)
    u, weights = mi.Float(rng.normal(size=size * size).astype(np.float32)), rng.normal(size=size * size)
    dr.enable_grad(u)
    solved = steps.from_differential(u)
    assert np.allclose(np.array(solved), np.linalg.solve(system, np.array(u)), atol=1e-5)
    dr.backward(dr.sum(solved * mi.Float(weights.astype(np.float32))))
    assert np.allclose(np.array(dr.grad(u)), np.linalg.solve(system, weights), atol=1e-5)
    with pytest.raises(ValueError, match="lambda"):
        HeightSteps(size, 0.0)


def test_large_steps_height_map_is_smoother_for_the_same_iterations_and_stays_finite(tmp_path):
    """large_steps_lambda > 0: the same tiny fit returns a relief of lower mean squared Laplacian, finite everywhere."""
    curvatures = {}
    for lambda_, rate in ((0.0, 0.05), (4.0, 0.5)):
        folder = tiny_relief_fit(tmp_path / str(lambda_), joint_iterations=4, learning_rate=rate, large_steps_lambda=lambda_)[1]
        curvatures[lambda_] = fitted_relief_curvature(folder)
    assert 0 < curvatures[4.0] < 0.5 * curvatures[0.0]  # the relief moved, and less from texel to texel


def test_cavity_factor_darkens_texels_below_their_ring_and_its_shade_is_written(tmp_path):
    """cavity > 0: the shade written with the fit is the cavity factor of the fitted height map (a dip darkens,
    a bump brightens, flat is 1), every number finite, and the fitted relief follows the photo's dark-is-deep pattern."""
    dip = np.zeros((16, 16))
    dip[8, 8] = -1.0
    factor = cavity_factor_np(dip, 2.0)
    assert factor[8, 8] < 0.3 and factor[0, 0] == 1.0 and cavity_factor_np(-dip, 2.0)[8, 8] > 1.7
    correlation = {}
    for strength in (0.0, 2.0):
        folder = tiny_relief_fit(tmp_path / str(strength), cavity=strength)[1]
        height = read_exr(folder / "height.exr")[..., 0]
        if strength > 0:
            assert np.allclose(read_exr(folder / "shade.exr")[..., 0], cavity_factor_np(height, strength), atol=1e-4)
            assert (folder / "albedo.exr").is_file()  # the re-render and scene.xml read the darkened colour
        target = read_exr(tmp_path / str(strength) / "prepared" / "image.exr")[..., :3]
        start = initial_height(target, 64, 0.06, 0.3)
        correlation[strength] = np.corrcoef(start, height.ravel())[0, 1]
    assert correlation[2.0] > correlation[0.0] + 0.1


def test_a_soft_light_is_calibrated_like_the_point_light(mi):
    """A white matte sheet reads 0.85 at the centre under either light; the soft one, far away, does not fall off."""
    camera, white = FitCamera(), Material((1.0, 1.0, 1.0), 0.0, 1.0)
    readings = {}
    for spread in (0.0, 20.0):
        fit = FitScene(camera, FitLight(30.0, 40.0, spread_deg=spread), plane_grid(camera, 8, 0.06), 0.06, white)
        image = np.array(mi.render(build_scene(mi, fit, 32, {"type": "direct"}, "multijitter"), spp=64, seed=1))[..., :3]
        readings[spread] = (float(image[14:18, 14:18].mean()), float(image.std()))
    assert readings[0.0][0] == pytest.approx(0.85, rel=0.02) and readings[20.0][0] == pytest.approx(0.85, rel=0.03)
    assert readings[20.0][1] < 0.1 * readings[0.0][1]


@pytest.mark.parametrize("spread", [0.0, 25.0])
def test_the_material_stage_keeps_the_light_that_lit_the_photo(tmp_path, mi, spread):
    """A photo of the fit model under a point or a soft light: the stage keeps that light and exports a scene that renders."""
    from clothscope.fit.outputs import LIGHT_FILE, save_state

    light, material = FitLight(35.0, 60.0), Material((0.5, 0.3, 0.2), 0.6, 0.25)
    render_case(mi, tmp_path / "photo.png", material, replace(light, spread_deg=spread), folded_grid(0.04))
    prepare_image("case", tmp_path / "photo.png", tmp_path / "prepared", config_settings("prepare", working_resolution=64, scale="frame"))
    camera = FitCamera()
    save_state(tmp_path / "geometry", FitScene(camera, light, folded_grid(0.04), 0.06, Material((0.4, 0.4, 0.4), 0.5, 0.5)), {})
    settings = config_settings("fit.material", resolution=32, spp=4, iterations=40, soft_light_deg=25.0)
    common = dict(variant="llvm_ad_rgb", threads=2, full_effects=False, log=LOG, sample_seed=0)
    state = jobs.material_job(str(tmp_path / "prepared"), str(tmp_path / "geometry"), str(tmp_path / "material"), settings, **common)
    choice = state["light_choice"]
    assert choice["chosen"] == ("soft" if spread else "point"), choice
    assert json.loads((tmp_path / "material" / "state.json").read_text())["scene"]["light"]["spread_deg"] == spread
    assert (tmp_path / "material" / LIGHT_FILE).exists() == bool(spread)
    rendered = np.array(mi.render(mi.load_file(str(tmp_path / "material" / "scene.xml")), spp=8))[..., :3]
    assert np.all(np.isfinite(rendered)) and rendered.mean() > 0.02

"""``direct_unshadowed``: one bounce from a point light, with no shadow ray.

Mitsuba's ``direct`` integrator always traces a shadow ray toward the light.
When the planner has shown that the fitted surface cannot shadow itself (see
:func:`.effects.casts_shadows`), that ray always reaches the light and is
wasted work, about a third of each iteration. This integrator evaluates the
same estimator without it: camera ray, surface interaction, one emitter
sample, BSDF value. Derivatives come from Dr.Jit's automatic differentiation of
:meth:`sample` (Mitsuba's ``ADIntegrator``), as for ``direct``.

Its reverse-mode pass skips a kernel. Mitsuba's ``ADIntegrator.render_backward``
splats the samples into an image block and evaluates it before it propagates
the image's adjoint back through the splat, so every gradient pass first renders
the image it then throws away. With a box filter and no border samples (what
the fit's scenes use), sample ``k`` of a pixel lands in that pixel alone with
weight ``1 / spp``, so its adjoint is the pixel's adjoint times the ray weight
over ``spp``; :meth:`render_backward` hands that to the samples directly and
Dr.Jit runs only the backward kernel. Any other film falls back to Mitsuba's pass.

With ``intersection_cache`` N > 0 it also keeps the ray-mesh intersections of
the last N (pass, seed, samples) renders and reuses them when the same rays come
again (``workflow/benchmarks/render_split.py`` times a render's parts).
The rays repeat only when a fit cycles through a fixed set of seeds
(``fit.normals.seed_cycle``), and the cache is right only while no vertex moves,
which holds in the normal-map stage, where the geometry is fixed.
"""
from __future__ import annotations

from types import ModuleType
from typing import Any

import drjit as dr

NAME = "direct_unshadowed"
_REGISTERED: set[str] = set()


def splats_one_pixel_per_sample(film: Any) -> bool:
    """Whether each sample of ``film`` lands in exactly one pixel with weight 1 (box filter, no border samples)."""
    return film.rfilter().is_box_filter() and not film.sample_border()


def register(mi: ModuleType) -> None:
    """Register the integrator for the active Mitsuba variant (once per variant and process)."""
    variant = str(mi.variant())
    if variant in _REGISTERED:
        return
    class UnshadowedDirect(mi.ad.integrators.common.ADIntegrator):
        """Emitter-sampled single scattering without visibility tests."""

        def __init__(self, props):
            super().__init__(props)
            self.cache_size = int(props.get("intersection_cache", 0))
            self.cache: dict[tuple, Any] = {}
            self.key: tuple | None = None

        def cache_key(self, kind, sensor, seed, spp):
            """What identifies a render's rays (None without a cache: the seed may be an array a recording cannot read)."""
            return (kind, int(seed), int(spp), sensor if isinstance(sensor, int) else id(sensor)) if self.cache_size else None

        def render(self, scene, sensor=0, seed=0, spp=0, develop=True, evaluate=True):
            self.key = self.cache_key("primal", sensor, seed, spp)
            return super().render(scene, sensor, seed, spp, develop, evaluate)

        def intersect(self, scene, ray, active):
            """The preliminary intersections of ``ray``: those kept for the current render's key, or found and kept."""
            found = self.cache.get(self.key)
            if found is None:
                found = scene.ray_intersect_preliminary(mi.Ray3f(ray), coherent=True, active=active)
                dr.eval(found)
                self.cache[self.key] = found
                while len(self.cache) > self.cache_size:
                    del self.cache[next(iter(self.cache))]  # the oldest
            return found

        def sample(self, mode, scene, sampler, ray, depth=None, δL=None, δaovs=None, state_in=None,  # noqa: PLC2401
                   active=True, **kwargs):
            with dr.resume_grad(when=mode != dr.ADMode.Primal):
                if self.cache_size:
                    with dr.suspend_grad():
                        found = self.intersect(scene, ray, active)
                    si = found.compute_surface_interaction(mi.Ray3f(ray), mi.RayFlags.All, active)
                else:
                    si = scene.ray_intersect(mi.Ray3f(ray), ray_flags=mi.RayFlags.All, coherent=True, active=active)
                valid = si.is_valid()
                ds, light = scene.sample_emitter_direction(si, sampler.next_2d(valid), False, valid)
                value = si.bsdf(ray).eval(mi.BSDFContext(), si, si.to_local(ds.d), valid)
                radiance = dr.select(valid & (ds.pdf != 0), value * light, 0.0)
            return radiance, valid, [], None

        def render_backward(self, scene, params, grad_in, sensor=0, seed=0, spp=0):
            """Propagate the image adjoint ``grad_in`` to the scene parameters, without rendering the image first."""
            self.key = self.cache_key("gradient", sensor, seed, spp)
            sensor = scene.sensors()[sensor] if isinstance(sensor, int) else sensor
            film = sensor.film()
            if not splats_one_pixel_per_sample(film):
                return super().render_backward(scene, params, grad_in, sensor, seed, spp)
            with dr.suspend_grad():
                sampler, spp = self.prepare(sensor, seed, spp, self.aov_names())
                ray, weight, _ = self.sample_rays(scene, sensor, sampler)
                pixel = dr.arange(mi.UInt32, dr.width(ray.o)) // spp  # sample_rays orders the samples pixel by pixel
                adjoint = dr.gather(mi.Color3f, grad_in.array, pixel) * weight / spp
                with dr.resume_grad():
                    radiance, _, _, _ = self.sample(mode=dr.ADMode.Backward, scene=scene, sampler=sampler, ray=ray,
                                                    active=mi.Bool(True))
                    dr.set_grad(radiance, adjoint)
                    dr.enqueue(dr.ADMode.Backward, radiance)
                    dr.traverse(dr.ADMode.Backward)
                del ray, weight, sampler
                dr.eval()

    mi.register_integrator(NAME, lambda props: UnshadowedDirect(props))
    _REGISTERED.add(variant)

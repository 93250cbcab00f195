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

        def sample(self, mode, scene, sampler, ray, depth=None, δL=None, δaovs=None, state_in=None,  # noqa: PLC2401
                   active=True, **kwargs):
            with dr.resume_grad(when=mode != dr.ADMode.Primal):
                si = scene.ray_intersect(mi.Ray3f(ray), ray_flags=mi.RayFlags.All, coherent=True, active=active)
                valid = si.is_valid()
                ds, light = scene.sample_emitter_direction(si, sampler.next_2d(valid), False, valid)
                value = si.bsdf(ray).eval(mi.BSDFContext(), si, si.to_local(ds.d), valid)
                radiance = dr.select(valid & (ds.pdf != 0), value * light, 0.0)
            return radiance, valid, [], None

        def render_backward(self, scene, params, grad_in, sensor=0, seed=0, spp=0):
            """Propagate the image adjoint ``grad_in`` to the scene parameters, without rendering the image first."""
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

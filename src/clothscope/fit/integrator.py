"""``direct_unshadowed``: one bounce from a point light, with no shadow ray.

Mitsuba's ``direct`` integrator always traces a shadow ray toward the light.
When the planner has shown that the fitted surface cannot shadow itself (see
:func:`.effects.casts_shadows`), that ray always reaches the light and is
wasted work, about a third of each iteration. This integrator evaluates the
same estimator without it: camera ray, surface interaction, one emitter
sample, BSDF value. Derivatives come from Dr.Jit's automatic differentiation of
:meth:`sample` (Mitsuba's ``ADIntegrator``), as for ``direct``.
"""
from __future__ import annotations

from types import ModuleType

import drjit as dr

NAME = "direct_unshadowed"
_REGISTERED: set[str] = set()


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

    mi.register_integrator(NAME, lambda props: UnshadowedDirect(props))
    _REGISTERED.add(variant)

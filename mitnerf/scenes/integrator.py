"""``all_lights``: deterministic direct lighting from every emitter of a scene.

Mitsuba's ``direct`` integrator picks one emitter at random per sample, which leaves
light-selection noise in multi-light scenes. The ground truth here only has point
(delta) lights, whose direct contribution needs no random numbers: this integrator sums
all of them, so the only thing a pixel still samples is its footprint (the tests bound
the noise against a render with 4x the samples).
The scene XML keeps Mitsuba's ``direct`` integrator for plain-Mitsuba users.
"""

from __future__ import annotations


def all_lights_integrator():
    """An instance for the *current* variant (Python integrators subclass a
    variant-specific base class, so the class is built on each call)."""
    import drjit as dr
    import mitsuba as mi

    class AllLightsIntegrator(mi.SamplingIntegrator):
        def __init__(self):
            super().__init__(mi.Properties())

        def sample(self, scene, sampler, ray, medium=None, active=True):
            si = scene.ray_intersect(ray, active)
            valid = si.is_valid() & active
            if not dr.is_jit_v(mi.Float) and not valid:   # scalar: no masking, si.bsdf() would crash
                return mi.Spectrum(0.0), False, []
            bsdf = si.bsdf(ray)
            ctx = mi.BSDFContext()
            result = mi.Spectrum(0.0)
            for emitter in scene.emitters():      # unrolled: ground-truth scenes have few lights
                ds, weight = emitter.sample_direction(si, mi.Point2f(0.5, 0.5), valid)
                lit = valid & (ds.pdf > 0)
                # dr.select, not ~: in scalar variants ~True is the int -2
                visible = lit & dr.select(scene.ray_test(si.spawn_ray_to(ds.p), lit), False, True)
                f = bsdf.eval(ctx, si, si.to_local(ds.d), visible)
                result += dr.select(visible, f * weight, 0.0)
            return result, valid, []

        def aov_names(self):
            return []

        def to_string(self):
            return "AllLightsIntegrator[]"

    return AllLightsIntegrator()

#!/usr/bin/env python3
"""torrey's own materials as Mitsuba 3 Python BSDF plugins, written independently from the
renderer as a reference. Formulas: the torrey course handouts (homework3.tex: Schlick Fresnel,
mirror, plastic; homework4.tex: phong, blinn, blinn_microfacet). Mitsuba's eval returns the BSDF
times the cosine, which is exactly the handouts' rho (their rho already includes it).

Usage (after mi.set_variant, e.g. 'llvm_ad_rgb'):
    import torrey_bsdfs; torrey_bsdfs.register()
then load scenes made by torrey_to_mitsuba.py (bsdf types torrey_mirror, torrey_plastic,
torrey_phong, torrey_blinn, torrey_blinn_microfacet). Self-test (white-furnace style energy
and pdf checks):  tests/mitsuba/.venv/bin/python tests/mitsuba/torrey_bsdfs.py

Local frame: z is the shading normal; wi points to the viewer, wo to the light (both out of the
surface). Conventions (view = wi):
  Schlick F(F0, c) = F0 + (1 - F0) (1 - c)^5
  mirror            delta reflection, weight F(reflectance, cos wi)
  plastic           F = F(((eta-1)/(eta+1))^2, cos wi): delta mirror with weight F (white),
                    plus (1 - F) reflectance cos(wo) / pi; sampled with probability F / 1 - F
  phong             reflectance (a+1)/(2 pi) max(r.wo, 0)^a, r = mirror of wi, wo above surface
  blinn             (a+2)/(4 pi (2 - 2^(-a/2))) F(reflectance, h.wo) (n.h)^a
  blinn_microfacet  F(reflectance, h.wo) D G / (4 cos wi), D = (a+2)/(2 pi) (n.h)^a,
                    G = G1(wi) G1(wo), Walter et al.'s rational fit for G1
Sampling: phong samples cos^a around r; blinn/blinn_microfacet sample h ~ (n.h)^a and reflect.
"""
import math

import drjit as dr
import mitsuba as mi

if __name__ == "__main__":
    mi.set_variant("llvm_ad_rgb")
elif mi.variant() is None:
    raise ImportError("torrey_bsdfs: call mitsuba.set_variant(...) before importing this module")


def schlick(f0, c):
    return f0 + (1.0 - f0) * dr.power(dr.maximum(1.0 - c, 0.0), 5.0)


def reflect_local(w):
    return mi.Vector3f(-w.x, -w.y, w.z)


def sample_power_lobe(sample, exponent):
    """Direction around +z with pdf (a+1)/(2pi) cos^a (solid angle)."""
    cos_t = dr.power(sample.x, 1.0 / (exponent + 1.0))
    sin_t = dr.safe_sqrt(1.0 - cos_t * cos_t)
    phi = 2.0 * math.pi * sample.y
    s, c = dr.sincos(phi)
    return mi.Vector3f(c * sin_t, s * sin_t, cos_t)


def lobe_pdf(cos_t, exponent):
    return (exponent + 1.0) / (2.0 * math.pi) * dr.power(dr.maximum(cos_t, 0.0), exponent)


def texture_param(props, name, default):
    if name in props:
        v = props[name]
        if isinstance(v, mi.Texture):
            return v
        return mi.load_dict({"type": "srgb", "color": v} if not isinstance(v, float)
                            else {"type": "uniform", "value": v})
    return mi.load_dict({"type": "uniform", "value": default})


class _Base(mi.BSDF):
    def __init__(self, props, flags):
        mi.BSDF.__init__(self, props)
        self.reflectance = texture_param(props, "reflectance", 1.0)
        self.exponent = props.get("exponent", 1.0)
        self.m_flags = flags
        self.m_components = [flags]

    def traverse(self, callback):
        callback.put_object("reflectance", self.reflectance, mi.ParamFlags.Differentiable)

    def eval_pdf(self, ctx, si, wo, active=True):
        return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

    def to_string(self):
        return "%s[exponent=%s]" % (type(self).__name__, self.exponent)


class TorreyMirror(_Base):
    def __init__(self, props):
        _Base.__init__(self, props, mi.BSDFFlags.DeltaReflection | mi.BSDFFlags.FrontSide)

    def sample(self, ctx, si, sample1, sample2, active=True):
        cos_i = mi.Frame3f.cos_theta(si.wi)
        active = active & (cos_i > 0)
        bs = dr.zeros(mi.BSDFSample3f)
        bs.wo = reflect_local(si.wi)
        bs.pdf = mi.Float(1.0)
        bs.eta = mi.Float(1.0)
        bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DeltaReflection)
        bs.sampled_component = mi.UInt32(0)
        value = schlick(self.reflectance.eval(si, active), cos_i)
        return bs, dr.select(active, value, 0.0)

    def eval(self, ctx, si, wo, active=True):
        return mi.Color3f(0.0)

    def pdf(self, ctx, si, wo, active=True):
        return mi.Float(0.0)


class TorreyPlastic(_Base):
    def __init__(self, props):
        _Base.__init__(self, props, mi.BSDFFlags.DeltaReflection | mi.BSDFFlags.DiffuseReflection
                       | mi.BSDFFlags.FrontSide)
        self.m_components = [mi.BSDFFlags.DeltaReflection | mi.BSDFFlags.FrontSide,
                             mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide]
        eta = props.get("eta", 1.5)
        self.f0 = ((eta - 1.0) / (eta + 1.0)) ** 2

    def fresnel(self, si):
        return schlick(mi.Float(self.f0), mi.Frame3f.cos_theta(si.wi))

    def sample(self, ctx, si, sample1, sample2, active=True):
        cos_i = mi.Frame3f.cos_theta(si.wi)
        active = active & (cos_i > 0)
        f = self.fresnel(si)
        has_spec = ctx.is_enabled(mi.BSDFFlags.DeltaReflection, 0)
        has_diff = ctx.is_enabled(mi.BSDFFlags.DiffuseReflection, 1)
        p_spec = f if (has_spec and has_diff) else (mi.Float(1.0) if has_spec else mi.Float(0.0))
        pick_spec = sample1 < p_spec
        bs = dr.zeros(mi.BSDFSample3f)
        diff_wo = mi.warp.square_to_cosine_hemisphere(sample2)
        bs.wo = dr.select(pick_spec, reflect_local(si.wi), diff_wo)
        bs.eta = mi.Float(1.0)
        bs.sampled_type = dr.select(pick_spec, mi.UInt32(+mi.BSDFFlags.DeltaReflection),
                                    mi.UInt32(+mi.BSDFFlags.DiffuseReflection))
        bs.sampled_component = dr.select(pick_spec, mi.UInt32(0), mi.UInt32(1))
        cos_o = mi.Frame3f.cos_theta(diff_wo)
        bs.pdf = dr.select(pick_spec, p_spec, (1.0 - p_spec) * cos_o / math.pi)
        kd = self.reflectance.eval(si, active)
        spec_w = f / p_spec
        diff_w = (1.0 - f) * kd / (1.0 - p_spec)
        value = dr.select(pick_spec, mi.Color3f(spec_w), diff_w)
        active = active & (bs.pdf > 0)
        return bs, dr.select(active, value, 0.0)

    def eval(self, ctx, si, wo, active=True):
        if not ctx.is_enabled(mi.BSDFFlags.DiffuseReflection, 1):
            return mi.Color3f(0.0)
        cos_i = mi.Frame3f.cos_theta(si.wi)
        cos_o = mi.Frame3f.cos_theta(wo)
        active = active & (cos_i > 0) & (cos_o > 0)
        v = (1.0 - self.fresnel(si)) * self.reflectance.eval(si, active) * cos_o / math.pi
        return dr.select(active, v, 0.0)

    def pdf(self, ctx, si, wo, active=True):
        if not ctx.is_enabled(mi.BSDFFlags.DiffuseReflection, 1):
            return mi.Float(0.0)
        cos_i = mi.Frame3f.cos_theta(si.wi)
        cos_o = mi.Frame3f.cos_theta(wo)
        active = active & (cos_i > 0) & (cos_o > 0)
        p_diff = (1.0 - self.fresnel(si)) if ctx.is_enabled(mi.BSDFFlags.DeltaReflection, 0) else 1.0
        return dr.select(active, p_diff * cos_o / math.pi, 0.0)


class TorreyPhong(_Base):
    def __init__(self, props):
        _Base.__init__(self, props, mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide)

    def sample(self, ctx, si, sample1, sample2, active=True):
        cos_i = mi.Frame3f.cos_theta(si.wi)
        r = reflect_local(si.wi)
        wo = mi.Frame3f(r).to_world(sample_power_lobe(sample2, self.exponent))
        active = active & (cos_i > 0) & (mi.Frame3f.cos_theta(wo) > 0)
        bs = dr.zeros(mi.BSDFSample3f)
        bs.wo = wo
        bs.pdf = dr.select(active, lobe_pdf(dr.dot(r, wo), self.exponent), 0.0)
        bs.eta = mi.Float(1.0)
        bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
        bs.sampled_component = mi.UInt32(0)
        active = active & (bs.pdf > 0)
        # eval / pdf = reflectance exactly
        return bs, dr.select(active, self.reflectance.eval(si, active), 0.0)

    def eval(self, ctx, si, wo, active=True):
        cos_i = mi.Frame3f.cos_theta(si.wi)
        cos_o = mi.Frame3f.cos_theta(wo)
        active = active & (cos_i > 0) & (cos_o > 0)
        r = reflect_local(si.wi)
        v = self.reflectance.eval(si, active) * lobe_pdf(dr.dot(r, wo), self.exponent)
        return dr.select(active, v, 0.0)

    def pdf(self, ctx, si, wo, active=True):
        cos_i = mi.Frame3f.cos_theta(si.wi)
        cos_o = mi.Frame3f.cos_theta(wo)
        active = active & (cos_i > 0) & (cos_o > 0)
        return dr.select(active, lobe_pdf(dr.dot(reflect_local(si.wi), wo), self.exponent), 0.0)


class _HalfVector(_Base):
    """Shared half-vector sampling for blinn and blinn_microfacet."""

    def __init__(self, props):
        _Base.__init__(self, props, mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide)

    def half_pdf(self, si, wo):
        h = dr.normalize(si.wi + wo)
        return lobe_pdf(h.z, self.exponent) / (4.0 * dr.dot(wo, h)), h

    def sample(self, ctx, si, sample1, sample2, active=True):
        cos_i = mi.Frame3f.cos_theta(si.wi)
        h = sample_power_lobe(sample2, self.exponent)
        wo = 2.0 * dr.dot(si.wi, h) * h - si.wi
        active = active & (cos_i > 0) & (mi.Frame3f.cos_theta(wo) > 0) & (dr.dot(si.wi, h) > 0)
        bs = dr.zeros(mi.BSDFSample3f)
        bs.wo = wo
        bs.eta = mi.Float(1.0)
        bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
        bs.sampled_component = mi.UInt32(0)
        value, pdf = self.eval_pdf(ctx, si, wo, active)
        bs.pdf = pdf
        active = active & (pdf > 0)
        return bs, dr.select(active, value / pdf, 0.0)

    def eval(self, ctx, si, wo, active=True):
        cos_i = mi.Frame3f.cos_theta(si.wi)
        cos_o = mi.Frame3f.cos_theta(wo)
        active = active & (cos_i > 0) & (cos_o > 0)
        h = dr.normalize(si.wi + wo)
        v = self.rho(si, wo, h, active)
        return dr.select(active, v, 0.0)

    def pdf(self, ctx, si, wo, active=True):
        cos_i = mi.Frame3f.cos_theta(si.wi)
        cos_o = mi.Frame3f.cos_theta(wo)
        active = active & (cos_i > 0) & (cos_o > 0)
        p, h = self.half_pdf(si, wo)
        return dr.select(active, p, 0.0)


class TorreyBlinn(_HalfVector):
    def rho(self, si, wo, h, active):
        a = self.exponent
        c = (a + 2.0) / (4.0 * math.pi * (2.0 - 2.0 ** (-a / 2.0)))
        f = schlick(self.reflectance.eval(si, active), dr.dot(h, wo))
        return c * f * dr.power(dr.maximum(h.z, 0.0), a)


def smith_g1_walter(w, h, exponent):
    cos_t = mi.Frame3f.cos_theta(w)
    tan_t = dr.safe_sqrt(1.0 - cos_t * cos_t) / cos_t
    a = dr.sqrt(0.5 * exponent + 1.0) / tan_t  # inf when tan_t == 0
    g = (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
    g = dr.select((a < 1.6) & (tan_t > 0), g, 1.0)
    return dr.select((dr.dot(w, h) > 0) & (cos_t > 0), g, 0.0)


class TorreyBlinnMicrofacet(_HalfVector):
    def rho(self, si, wo, h, active):
        a = self.exponent
        d = (a + 2.0) / (2.0 * math.pi) * dr.power(dr.maximum(h.z, 0.0), a)
        g = smith_g1_walter(si.wi, h, a) * smith_g1_walter(wo, h, a)
        f = schlick(self.reflectance.eval(si, active), dr.dot(h, wo))
        return f * d * g / (4.0 * mi.Frame3f.cos_theta(si.wi))


PLUGINS = {
    "torrey_mirror": TorreyMirror,
    "torrey_plastic": TorreyPlastic,
    "torrey_phong": TorreyPhong,
    "torrey_blinn": TorreyBlinn,
    "torrey_blinn_microfacet": TorreyBlinnMicrofacet,
}


def register():
    for name, cls in PLUGINS.items():
        mi.register_bsdf(name, (lambda c: (lambda props: c(props)))(cls))


def _self_test():
    """Albedo by sampling vs by integrating eval over the hemisphere, and pdf normalisation."""
    import numpy as np
    register()
    n = 1 << 18
    rng = np.random.default_rng(1)
    for name in ["torrey_phong", "torrey_blinn", "torrey_blinn_microfacet", "torrey_plastic"]:
        for theta_deg in (0.0, 45.0, 75.0):
            bsdf = mi.load_dict({"type": name, "reflectance": {"type": "rgb", "value": [0.8, 0.5, 0.2]},
                                 "exponent": 30.0} if name != "torrey_plastic" else
                                {"type": name, "reflectance": {"type": "rgb", "value": [0.8, 0.5, 0.2]}})
            t = math.radians(theta_deg)
            si = dr.zeros(mi.SurfaceInteraction3f, n)
            si.wi = mi.Vector3f(math.sin(t), 0.0, math.cos(t))
            si.n = mi.Normal3f(0, 0, 1)
            si.sh_frame = mi.Frame3f(si.n)
            ctx = mi.BSDFContext()
            s1 = mi.Float(rng.random(n).astype(np.float32))
            s2 = mi.Point2f(mi.Float(rng.random(n).astype(np.float32)), mi.Float(rng.random(n).astype(np.float32)))
            bs, w = bsdf.sample(ctx, si, s1, s2)
            albedo_sampled = np.array(dr.mean(w, axis=1) if hasattr(dr, "mean") else w).ravel()
            # uniform hemisphere estimate of the smooth part
            wo = mi.warp.square_to_uniform_hemisphere(s2)
            v, p = bsdf.eval_pdf(ctx, si, wo)
            albedo_eval = np.array(v).mean(axis=1) * 2 * math.pi
            pdf_int = float(np.array(p).mean() * 2 * math.pi)
            print("%-24s theta %4.0f  albedo(sample) %s  albedo(eval) %s  int pdf %.3f" % (
                name, theta_deg, np.round(np.array(w).mean(axis=1), 4), np.round(albedo_eval, 4), pdf_int))


if __name__ == "__main__":
    _self_test()

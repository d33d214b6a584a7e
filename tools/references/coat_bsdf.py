"""A clear coat over the glTF BRDF (KHR_materials_clearcoat) as a Mitsuba 3 BSDF plugin
("gltf_coated"), for the clear-coat reference.

The model is the extension's layering (KHR_materials_clearcoat, "Layering": the material
below and the coat's specular lobe mixed by `fresnel_coat`, with the coat's index 1.5 and the
Fresnel term taken at the angle between the view and the coat's normal, N.V, not at V.H), with
no energy compensation: strata's `Layered` (src/shading/layers.rs) rendered with
`--energy-compensation off`. Notation: Mitsuba's names, wi = si.wi the direction toward the
viewer, wo the direction toward the light, both in the shading frame, whose normal is the
coat's (the conversion refuses clearcoatNormalTexture, so the coat's normal is the vertex
normal, as is the base's: no normal maps). With c = clearcoat (the coat's weight), alpha_c =
clearcoat_roughness^2 and n = +z:

    Fc     = f0 + (1 - f0) (1 - n.wi)^5        Schlick's Fresnel at the view angle; f0 = 0.04
                                               (index 1.5: ((1.5 - 1) / (1.5 + 1))^2)
    w      = c Fc                              the coat's share, a function of wi alone
    f cos  = w f_coat(wi, wo) n.wo + (1 - w) f_base(wi, wo) n.wo
    f_coat = D(h) V(wi, wo)                    GGX of alpha_c around n, h = normalize(wi + wo),
                                               V = G2 / (4 n.wi n.wo) height-correlated
                                               (glTF 2.0 Appendix B; Heitz 2014, eq. 99):
      D = alpha_c^2 / (pi ((n.h)^2 (alpha_c^2 - 1) + 1)^2)
      V = 0.5 / (n.wo sqrt((n.wi)^2 (1 - alpha_c^2) + alpha_c^2)
                 + n.wi sqrt((n.wo)^2 (1 - alpha_c^2) + alpha_c^2))

f_coat has no Fresnel factor of its own (the mix's w is the coat's Fresnel) and is not divided
by its albedo (no energy compensation). f_base is the nested `base` BSDF, the glTF BRDF of
gltf_bsdf.py (`gltf_metal_rough`), unchanged by the coat. Below alpha_c = 1e-3 the coat is
smooth: a mirror about n of weight w, a delta lobe that only `sample` produces (`eval` and `pdf`
leave it out); a smooth base's mirror under it is the base's own delta lobe, weighted 1 - w.

Two-sided as gltf_bsdf.py: where si.wi lies below the shading frame's surface, both directions'
z are negated before the coat is evaluated (the base does the same on its own), so both faces
show the same material.

Sampling: the coat with probability P = w (the share of the light it returns toward wi; 0 when
c = 0), the base with 1 - P, reusing sample1 rescaled into [0, 1). The coat's glossy lobe
reflects wi about a visible normal of `mi.MicrofacetDistribution(GGX, alpha_c,
sample_visible=True)` (density G1(wi) D(h) / (4 n.wi) in wo); the base samples itself. `pdf` is
the mixture's density P pdf_coat + (1 - P) pdf_base of the continuous lobes, and a continuous
sample's weight is the mixture's eval / pdf at the direction drawn, whichever lobe drew it. A
delta sample's weight is its lobe's weight over its probability: the coat's mirror w / P = 1
with probability P, the base's mirror (1 - w) F / ((1 - P) P_base) with probability (1 - P)
P_base (its expectation, summed over both mirrors where both exist, is w + (1 - w) F, the
light the two mirrors return together). When the BSDFContext enables only some components
(0 = the coat, 1.. = the base's), P is 1 or 0 where only one side is enabled.

Parameters:
- base: a nested BSDF (gltf_metal_rough); required;
- clearcoat: float in [0, 1] (default 0): clearcoatFactor;
- clearcoat_roughness: float in [0, 1] (default 0): clearcoatRoughnessFactor (alpha_c = r^2);
- coat_f0: float (default 0.04): the coat's reflectance at normal incidence. Only negative
  controls change it (0.028: a coat of index 1.4 instead of the extension's 1.5).
- attenuate_base: bool (default true): the base weighted by 1 - w. Only negative controls turn
  it off (f cos = w f_coat n.wo + f_base n.wo: the coat added on top, gaining energy).

Variants: RGB ones (scalar_rgb, llvm_ad_rgb). Use:

    import mitsuba as mi; mi.set_variant("llvm_ad_rgb")
    import gltf_bsdf, coat_bsdf; gltf_bsdf.register(); coat_bsdf.register()
    mi.load_dict({"type": "gltf_coated", "clearcoat": 1.0, "clearcoat_roughness": 0.3,
                  "base": {"type": "gltf_metal_rough", "base_color": {"type": "rgb", "value": [.3, .5, .9]},
                           "metallic": 1.0, "roughness": 0.6}})
"""
import drjit as dr
import mitsuba as mi

PLUGIN_NAME = "gltf_coated"
# Below this GGX alpha the coat is a perfect mirror (strata: Ggx::SMOOTH_ALPHA).
SMOOTH_ALPHA = 1e-3
COAT_F0 = 0.04  # Schlick's f0 of the extension's coat, index 1.5
ALL_COMPONENTS = 0xFFFFFFFF  # BSDFContext.component when no single component is selected

_registered = set()


def register():
    """Registers the plugin in the current variant (once per variant)."""
    variant = mi.variant()
    if variant is None or not variant.endswith("_rgb"):
        raise RuntimeError(f"coat_bsdf: needs an RGB variant (scalar_rgb, llvm_ad_rgb), not {variant}")
    if variant in _registered:
        return
    cls = _make_class()
    mi.register_bsdf(PLUGIN_NAME, lambda props: cls(props))
    _registered.add(variant)


def _make_class():
    # Defined per variant: mi.BSDF and the array types are the current variant's.
    F = mi.BSDFFlags
    sides = F.FrontSide | F.BackSide

    def coat_fresnel(f0, cos):
        m = dr.clip(1.0 - cos, 0.0, 1.0)
        m2 = m * m
        return f0 + (1.0 - f0) * (m2 * m2 * m)

    def visibility(alpha, cos_i, cos_o):
        """V = G2 / (4 cos_i cos_o), GGX's height-correlated masking-shadowing."""
        a2 = alpha * alpha
        denom = (cos_o * dr.sqrt(cos_i * cos_i * (1.0 - a2) + a2)
                 + cos_i * dr.sqrt(cos_o * cos_o * (1.0 - a2) + a2))
        return dr.select(denom > 0, 0.5 / dr.maximum(denom, 1e-30), 0.0)

    def upright(si_wi, wo):
        """(flip, wi, wo): both directions' z negated where si.wi is below the surface."""
        flip = mi.Frame3f.cos_theta(si_wi) < 0.0
        wi = mi.Vector3f(si_wi.x, si_wi.y, dr.abs(si_wi.z))
        return flip, wi, mi.Vector3f(wo.x, wo.y, dr.select(flip, -wo.z, wo.z))

    class GltfCoated(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            if "base" not in props.keys():
                raise ValueError(f"{PLUGIN_NAME}: a nested `base` BSDF is required")
            self.base = props.get("base")
            self.weight = min(max(float(props.get("clearcoat", 0.0)), 0.0), 1.0)
            rough = min(max(float(props.get("clearcoat_roughness", 0.0)), 0.0), 1.0)
            self.alpha = rough * rough
            self.f0 = float(props.get("coat_f0", COAT_F0))
            self.attenuate_base = bool(props.get("attenuate_base", True))
            self.smooth = self.alpha < SMOOTH_ALPHA
            coat = (+F.DeltaReflection if self.smooth else +F.GlossyReflection) | +sides
            self.m_components = [coat] + [self.base.flags(k) for k in range(self.base.component_count())]
            flags = 0
            for c in self.m_components:
                flags |= c
            self.m_flags = flags

        # -- helpers --------------------------------------------------------------------

        def _coat_type(self):
            return F.DeltaReflection if self.smooth else F.GlossyReflection

        def _contexts(self, ctx):
            """(coat enabled, base enabled, the base's context: component k of the base is
            component k + 1 here)."""
            component = int(ctx.component)
            coat_on = self.weight > 0.0 and ctx.is_enabled(self._coat_type(), 0)
            if component == ALL_COMPONENTS:
                return coat_on, True, ctx
            if component == 0:
                return coat_on, False, ctx
            return False, True, mi.BSDFContext(ctx.mode, ctx.type_mask, component - 1)

        def _share(self, cos_i, coat_on, base_on):
            """(w, P): the coat's weight c Fc(n.wi) and its sampling probability."""
            w = self.weight * coat_fresnel(self.f0, cos_i)
            if coat_on and base_on:
                p = w
            else:
                p = mi.Float(1.0 if coat_on else 0.0)
            return w, p

        def _base_weight(self, w):
            """The base's weight under the coat: 1 - w (1 in the additive negative control)."""
            return 1.0 - w if self.attenuate_base else 1.0

        def _distribution(self):
            return mi.MicrofacetDistribution(mi.MicrofacetType.GGX, max(self.alpha, SMOOTH_ALPHA), True)

        def _eval_pdf(self, ctx, si, wo, active):
            coat_on, base_on, base_ctx = self._contexts(ctx)
            _, wi_u, wo_u = upright(si.wi, wo)
            cos_i, cos_o = wi_u.z, wo_u.z
            active = active & (cos_i > 0.0)
            w, p = self._share(cos_i, coat_on, base_on)
            value = mi.Color3f(0.0)
            pdf = mi.Float(0.0)
            if base_on:
                base_value, base_pdf = self.base.eval_pdf(base_ctx, si, wo, active)
                value += self._base_weight(w) * base_value
                pdf += (1.0 - p) * base_pdf
            if coat_on and not self.smooth:
                above = active & (cos_o > 0.0)
                h = dr.normalize(wi_u + wo_u)
                distr = self._distribution()
                d = distr.eval(h)
                coat = d * visibility(self.alpha, cos_i, cos_o) * cos_o
                coat_pdf = distr.pdf(wi_u, h) / (4.0 * dr.maximum(dr.dot(wo_u, h), 1e-30))
                value += dr.select(above, w * coat, 0.0)
                pdf += dr.select(above & (dr.dot(wo_u, h) > 0.0), p * coat_pdf, 0.0)
            return dr.select(active, value, 0.0), dr.select(active, pdf, 0.0)

        # -- the BSDF interface ---------------------------------------------------------

        def eval(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)[1]

        def eval_pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            coat_on, base_on, base_ctx = self._contexts(ctx)
            flip, wi_u, _ = upright(si.wi, si.wi)
            cos_i = wi_u.z
            active = active & (cos_i > 0.0)
            w, p = self._share(cos_i, coat_on, base_on)
            # (Masks are combined with & and | only: in scalar variants they are Python bools.)
            pick_coat, pick_base = sample1 < p, sample1 >= p

            # The coat's direction (upright, then turned back to the query's side).
            if self.smooth:
                wo_coat = mi.Vector3f(-wi_u.x, -wi_u.y, wi_u.z)
            else:
                m, _ = self._distribution().sample(wi_u, sample2)
                wo_coat = mi.reflect(wi_u, m)
            coat_ok = wo_coat.z > 0.0
            wo_coat = mi.Vector3f(wo_coat.x, wo_coat.y, dr.select(flip, -wo_coat.z, wo_coat.z))

            # The base's sample, with sample1 rescaled into [0, 1) over its share.
            if base_on:
                s1 = dr.clip((sample1 - p) / dr.maximum(1.0 - p, 1e-30), 0.0, 0.99999994)
                bs_base, w_base = self.base.sample(base_ctx, si, s1, sample2, active & pick_base)
                base_ok = bs_base.pdf > 0.0
                base_delta = mi.has_flag(bs_base.sampled_type, F.Delta)
                base_continuous = mi.has_flag(bs_base.sampled_type, F.Glossy) | mi.has_flag(
                    bs_base.sampled_type, F.Diffuse)
            else:
                bs_base, w_base = mi.BSDFSample3f(), mi.Color3f(0.0)
                base_ok = base_delta = base_continuous = mi.Bool(False)

            wo = dr.select(pick_coat, wo_coat, bs_base.wo)
            valid = active & ((pick_coat & coat_ok) | (pick_base & base_ok))
            coat_delta = pick_coat if self.smooth else mi.Bool(False)
            coat_continuous = mi.Bool(False) if self.smooth else pick_coat
            base_delta = pick_base & base_delta
            continuous = coat_continuous | (pick_base & base_continuous)

            # Continuous lobes: the mixture's value and density at the direction drawn.
            value, pdf = self._eval_pdf(ctx, si, wo, valid & continuous)
            weight = dr.select(pdf > 0.0, value / dr.maximum(pdf, 1e-30), 0.0)
            # The mirrors: the lobe's weight over the probability of drawing it.
            weight = dr.select(coat_delta, w / dr.maximum(p, 1e-30), weight)
            pdf = dr.select(coat_delta, p, pdf)
            weight = dr.select(base_delta, self._base_weight(w) * w_base / dr.maximum(1.0 - p, 1e-30), weight)
            pdf = dr.select(base_delta, (1.0 - p) * bs_base.pdf, pdf)
            valid = valid & (pdf > 0.0)

            bs = mi.BSDFSample3f()
            bs.wo = wo
            bs.pdf = dr.select(valid, pdf, 0.0)
            bs.eta = 1.0
            bs.sampled_component = dr.select(pick_coat, mi.UInt32(0), bs_base.sampled_component + 1)
            bs.sampled_type = dr.select(pick_coat, mi.UInt32(+self._coat_type()), bs_base.sampled_type)
            return bs, dr.select(valid, weight, 0.0)

        def eval_diffuse_reflectance(self, si, active=True):
            return self.base.eval_diffuse_reflectance(si, active)

        def to_string(self):
            return (f"GltfCoated[clearcoat={self.weight}, alpha={self.alpha}, coat_f0={self.f0}, "
                    f"attenuate_base={self.attenuate_base}, base={self.base}]")

    return GltfCoated

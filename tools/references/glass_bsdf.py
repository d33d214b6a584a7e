"""strata's glass BSDFs (src/shading/dielectric.rs) as Mitsuba 3 BSDF plugins, for the glass
references (KHR_materials_transmission, _volume, _ior).

Two plugins, both written from the formulas alone (no code shared with strata); GGX's D,
Smith's G1 and the sampling of visible normals (Heitz 2018) are Mitsuba's own
(`mi.MicrofacetDistribution(GGX, alpha, sample_visible=True)`), Fresnel is `mi.fresnel` (the
exact unpolarized reflectance of a dielectric) and refraction `mi.refract`.

Notation: Mitsuba's names. wi = si.wi, the direction toward the camera (strata's wo); wo the
direction toward the light (strata's wi); both in the shading frame, n = +z. alpha the GGX
roughness (glTF roughness^2); Lambda(w) = (-1 + sqrt(1 + alpha^2 tan^2 theta_w)) / 2 (GGX's
Smith Lambda); G2(wi, wo) = 1 / (1 + Lambda(wi) + Lambda(wo)), the height-correlated
masking-shadowing (Heitz 2014, eq. 99, the form strata and pbrt-v4 use for both lobes), written
out here; V = G2 / (4 |n.wi| |n.wo|).

"gltf_rough_dielectric": the rough interface of a transmissive volume (strata's `Dielectric`,
alpha >= 1e-3; a smooth one is Mitsuba's own `dielectric`, the same model). The outside is the
side +z points to, the inside has relative index eta = n_inside / n_outside (int_ior / ext_ior).
A query from inside (wi.z < 0) is turned upright (both directions negated) and sees eta' = 1/eta;
above eta' = eta. Upright, Walter et al. 2007 ("Microfacet Models for Refraction through Rough
Surfaces"):

    reflection (wo.z > 0): h = normalize(wi + wo)
        f cos = F(wi.h) D(h) G2 / (4 n.wi)                                          (eq. 20)
        pdf   = F(wi.h) D_wi(h) / (4 wi.h)                                          (eq. 14)
    transmission (wo.z < 0): h = +-normalize(wi + eta' wo), turned to +z           (eq. 16)
        f cos = (1 - F(wi.h)) T D(h) G2 |wi.h| |wo.h| / (n.wi (wi.h + eta' wo.h)^2)  (eq. 21)
        pdf   = (1 - F(wi.h)) D_wi(h) eta'^2 |wo.h| / (wi.h + eta' wo.h)^2           (eq. 17)

with D_wi(h) = G1(wi) D(h) (wi.h) / (n.wi) the density of the normals visible from wi, T the
transmittance (glTF: the base colour), and h required to face both directions on their sides
(wi.h > 0, wo.h of the sign of wo.z). The transmission is the radiance form (Veach 1997, §5.2):
eq. 21's eta_o^2 / (eta_o wi.h + eta_i wo.h)^2 with the camera's side at index 1, so radiance
entering glass is divided by eta^2 and leaving it multiplied (pbrt-v4's TransportMode::Radiance,
strata's convention). In TransportMode::Importance the factor eta'^2 is left out (multiplied
back), as Mitsuba's `roughdielectric` does. This is Mitsuba's `roughdielectric` except for the
masking-shadowing: Mitsuba's is separable, G1(wi) G1(wo) (check_glass_bsdf.py checks that the
two differ by exactly that ratio).

Sampling: a visible normal m from wi (upright), then reflection about m with probability
F(wi.m), refraction through it otherwise (total internal reflection: F = 1); the sample's
weight is (f cos) / pdf of the direction drawn, as eval_pdf gives them.

"gltf_thin_dielectric": the thin-walled surface of KHR_materials_transmission without a
volume (strata's `ThinDielectric`): two interfaces of an infinitely thin sheet, light leaves on
the far side unbent. Upright (wi.z > 0) and with wo' = (wo.x, wo.y, |wo.z|), h = normalize(wi + wo'):

    reflection (wo.z > 0):   f cos = F(wi.h) D(h) V(wi, wo') n.wo',      pdf = F D_wi(h) / (4 wi.h)
    transmission (wo.z < 0): f cos = (1 - F(wi.h)) T D(h) V(wi, wo') n.wo', pdf = (1 - F) D_wi(h) / (4 wi.h)

the transmission being the reflection lobe mirrored through the plane (the extension's BTDF,
evaluated with its half vector H_T), F the Fresnel reflectance of index eta seen from the
outside on either side (the sheet is symmetric), and no eta^2 factor (light returns to the
medium it came from). Below alpha = 1e-3 the sheet is smooth: the mirror direction with weight
1 (F(n.wi) f cos over probability F(n.wi)) and straight through (wo = -wi) with weight T
(probability 1 - F). Sampling: a visible normal m, the reflection about it, kept with
probability F(wi.m) or mirrored through the plane otherwise.

Mitsuba's own `thindielectric` is a different sheet: it sums the light reflected back and forth
between the two faces, R = r + (1 - r)^2 r / (1 - r^2) = 2r / (1 + r), T = (1 - r) / (1 + r)
(smooth only). The glass references use it as a negative control.

Parameters: eta (float > 0: int_ior / ext_ior; thin: the sheet's index relative to the
surroundings), alpha (float, the GGX alpha), specular_transmittance (texture or RGB, default 1).
RGB variants (scalar_rgb, llvm_ad_rgb).
"""
import drjit as dr
import mitsuba as mi

ROUGH_NAME = "gltf_rough_dielectric"
THIN_NAME = "gltf_thin_dielectric"
# Below this GGX alpha a surface is smooth (strata: Ggx::SMOOTH_ALPHA).
SMOOTH_ALPHA = 1e-3

_registered = set()


def register():
    """Registers both plugins in the current variant (once per variant)."""
    variant = mi.variant()
    if variant is None or not variant.endswith("_rgb"):
        raise RuntimeError(f"glass_bsdf: needs an RGB variant (scalar_rgb, llvm_ad_rgb), not {variant}")
    if variant in _registered:
        return
    rough, thin = _make_classes()
    mi.register_bsdf(ROUGH_NAME, lambda props: rough(props))
    mi.register_bsdf(THIN_NAME, lambda props: thin(props))
    _registered.add(variant)


def smith_lambda(alpha, w):
    """GGX's Smith Lambda of direction w (|w.z| used: either side)."""
    c2 = dr.square(w.z)
    s2 = dr.maximum(1.0 - c2, 0.0)
    return 0.5 * (dr.sqrt(1.0 + dr.square(alpha) * s2 / dr.maximum(c2, 1e-30)) - 1.0)


def g2(alpha, a, b):
    """The height-correlated masking-shadowing 1 / (1 + Lambda(a) + Lambda(b))."""
    return 1.0 / (1.0 + smith_lambda(alpha, a) + smith_lambda(alpha, b))


def _make_classes():
    # Defined per variant: mi.BSDF and the array types are the current variant's.
    F = mi.BSDFFlags
    sides = F.FrontSide | F.BackSide

    def upright(si_wi, wo):
        """(flip, wi, wo) with wi turned to +z (both directions negated when it was below)."""
        flip = si_wi.z < 0.0
        sign = dr.select(flip, -1.0, 1.0)
        return flip, si_wi * sign, wo * sign

    class RoughDielectric(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.eta = props.get("eta", 1.5)
            self.alpha = props.get("alpha", 0.1)
            if not self.alpha >= SMOOTH_ALPHA:
                raise ValueError(f"{ROUGH_NAME}: alpha {self.alpha} < {SMOOTH_ALPHA} is smooth: use `dielectric`")
            if not (self.eta > 0 and self.eta != 1.0):
                raise ValueError(f"{ROUGH_NAME}: eta must be positive and not 1 (got {self.eta})")
            self.transmittance = props.get_texture("specular_transmittance", 1.0)
            self.m_components = [+F.GlossyReflection | +sides,
                                 +F.GlossyTransmission | +sides | +F.NonSymmetric]
            self.m_flags = self.m_components[0] | self.m_components[1]

        def _lobes(self, ctx):
            return ctx.is_enabled(F.GlossyReflection, 0), ctx.is_enabled(F.GlossyTransmission, 1)

        def _distribution(self):
            return mi.MicrofacetDistribution(mi.MicrofacetType.GGX, self.alpha, True)

        def _eval_pdf(self, ctx, si, wo, active):
            refl_on, trans_on = self._lobes(ctx)
            flip, wi, wo = upright(si.wi, wo)
            eta = dr.select(flip, 1.0 / self.eta, self.eta)
            reflect = wo.z > 0.0
            active = active & (wi.z > 0.0) & (wo.z != 0.0)
            # The generalized half vector (Walter eq. 16), turned to +z.
            h = wi + dr.select(reflect, 1.0, eta) * wo
            h = dr.normalize(h) * dr.select(h.z < 0.0, -1.0, 1.0)
            wi_h, wo_h = dr.dot(wi, h), dr.dot(wo, h)
            active = active & (wi_h > 0.0) & (wo_h * wo.z > 0.0)
            distr = self._distribution()
            d = distr.eval(h)
            f, _, _, _ = mi.fresnel(wi_h, eta)
            g = g2(self.alpha, wi, wo)
            pdf_h = distr.pdf(wi, h)  # visible normals: G1(wi) D (wi.h) / n.wi
            p_r = f if (refl_on and trans_on) else (1.0 if refl_on else 0.0)
            # reflection
            value_r = f * d * g / (4.0 * wi.z)
            pdf_r = p_r * pdf_h / (4.0 * wi_h)
            # transmission (radiance: eta'^2 left out; importance: put back)
            denom = dr.square(wi_h + eta * wo_h)
            value_t = (1.0 - f) * d * g * dr.abs(wi_h * wo_h) / (wi.z * denom)
            if ctx.mode == mi.TransportMode.Importance:
                value_t = value_t * dr.square(eta)
            pdf_t = (1.0 - p_r) * pdf_h * dr.square(eta) * dr.abs(wo_h) / denom
            tint = self.transmittance.eval(si, active)
            on_r = active & reflect & refl_on
            on_t = active & (wo.z < 0.0) & trans_on
            value = dr.select(on_r, mi.Color3f(value_r), dr.select(on_t, tint * value_t, mi.Color3f(0.0)))
            pdf = dr.select(on_r, pdf_r, dr.select(on_t, pdf_t, 0.0))
            ok = dr.isfinite(pdf) & dr.all(dr.isfinite(value))
            return dr.select(ok, value, mi.Color3f(0.0)), dr.select(ok, pdf, 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)[1]

        def eval_pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            refl_on, trans_on = self._lobes(ctx)
            flip, wi, _ = upright(si.wi, si.wi)
            eta = dr.select(flip, 1.0 / self.eta, self.eta)
            active = active & (wi.z > 0.0)
            m, _ = self._distribution().sample(wi, sample2)
            f, cos_t, _, eta_ti = mi.fresnel(dr.dot(wi, m), eta)
            p_r = f if (refl_on and trans_on) else (1.0 if refl_on else 0.0)
            pick_r = sample1 < p_r
            wo = dr.select(pick_r, mi.reflect(wi, m), mi.refract(wi, m, cos_t, eta_ti))
            active = active & dr.select(pick_r, wo.z > 0.0, wo.z < 0.0)
            wo_world = dr.select(flip, -wo, wo)
            value, pdf = self._eval_pdf(ctx, si, wo_world, active)
            active = active & (pdf > 0.0)
            bs = mi.BSDFSample3f()
            bs.wo = wo_world
            bs.pdf = dr.select(active, pdf, 0.0)
            bs.eta = dr.select(pick_r, 1.0, eta)
            bs.sampled_component = dr.select(pick_r, mi.UInt32(0), mi.UInt32(1))
            bs.sampled_type = dr.select(pick_r, mi.UInt32(+F.GlossyReflection), mi.UInt32(+F.GlossyTransmission))
            weight = dr.select(active, value / dr.maximum(pdf, 1e-30), mi.Color3f(0.0))
            return bs, weight

        def to_string(self):
            return f"GltfRoughDielectric[eta={self.eta}, alpha={self.alpha}, specular_transmittance={self.transmittance}]"

    class ThinDielectric(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.eta = props.get("eta", 1.5)
            self.alpha = props.get("alpha", 0.0)
            if not self.eta > 0:
                raise ValueError(f"{THIN_NAME}: eta must be positive (got {self.eta})")
            self.transmittance = props.get_texture("specular_transmittance", 1.0)
            self.smooth = self.alpha < SMOOTH_ALPHA
            if self.smooth:
                self.kinds = (F.DeltaReflection, F.DeltaTransmission)
            else:
                self.kinds = (F.GlossyReflection, F.GlossyTransmission)
            self.m_components = [+self.kinds[0] | +sides, +self.kinds[1] | +sides]
            self.m_flags = self.m_components[0] | self.m_components[1]

        def _lobes(self, ctx):
            return ctx.is_enabled(self.kinds[0], 0), ctx.is_enabled(self.kinds[1], 1)

        def _eval_pdf(self, ctx, si, wo, active):
            if self.smooth:  # delta lobes: nothing to evaluate
                return mi.Color3f(0.0), mi.Float(0.0)
            refl_on, trans_on = self._lobes(ctx)
            _, wi, wo = upright(si.wi, wo)
            reflect = wo.z > 0.0
            wr = mi.Vector3f(wo.x, wo.y, dr.abs(wo.z))  # the reflection lobe's direction
            active = active & (wi.z > 0.0) & (wo.z != 0.0)
            h = dr.normalize(wi + wr)
            wi_h = dr.dot(wi, h)
            active = active & (wi_h > 0.0)
            distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, self.alpha, True)
            d = distr.eval(h)
            f, _, _, _ = mi.fresnel(wi_h, self.eta)
            p_r = f if (refl_on and trans_on) else (1.0 if refl_on else 0.0)
            lobe = d * g2(self.alpha, wi, wr) / (4.0 * wi.z)  # D V n.wo'
            pdf_lobe = distr.pdf(wi, h) / (4.0 * wi_h)
            tint = self.transmittance.eval(si, active)
            on_r = active & reflect & refl_on
            on_t = active & (wo.z < 0.0) & trans_on
            value = dr.select(on_r, mi.Color3f(f * lobe),
                              dr.select(on_t, tint * ((1.0 - f) * lobe), mi.Color3f(0.0)))
            pdf = dr.select(on_r, p_r * pdf_lobe, dr.select(on_t, (1.0 - p_r) * pdf_lobe, 0.0))
            ok = dr.isfinite(pdf) & dr.all(dr.isfinite(value))
            return dr.select(ok, value, mi.Color3f(0.0)), dr.select(ok, pdf, 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)[1]

        def eval_pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            refl_on, trans_on = self._lobes(ctx)
            flip, wi, _ = upright(si.wi, si.wi)
            active = active & (wi.z > 0.0)
            bs = mi.BSDFSample3f()
            bs.eta = 1.0
            if self.smooth:
                f, _, _, _ = mi.fresnel(wi.z, self.eta)
                p_r = f if (refl_on and trans_on) else (1.0 if refl_on else 0.0)
                pick_r = sample1 < p_r
                wo = dr.select(pick_r, mi.Vector3f(-wi.x, -wi.y, wi.z), -wi)
                pdf = dr.select(pick_r, p_r, 1.0 - p_r)
                active = active & (pdf > 0.0)
                # f cos / pdf: F / P and (1 - F) T / (1 - P); with both lobes on, 1 and T.
                tint = self.transmittance.eval(si, active)
                weight = dr.select(pick_r, mi.Color3f(f / dr.maximum(pdf, 1e-30)),
                                   tint * ((1.0 - f) / dr.maximum(pdf, 1e-30)))
            else:
                distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, self.alpha, True)
                m, _ = distr.sample(wi, sample2)
                f, _, _, _ = mi.fresnel(dr.dot(wi, m), self.eta)
                p_r = f if (refl_on and trans_on) else (1.0 if refl_on else 0.0)
                pick_r = sample1 < p_r
                wr = mi.reflect(wi, m)
                active = active & (wr.z > 0.0)
                wo = dr.select(pick_r, wr, mi.Vector3f(wr.x, wr.y, -wr.z))
                value, pdf = self._eval_pdf(ctx, si, dr.select(flip, -wo, wo), active)
                active = active & (pdf > 0.0)
                weight = value / dr.maximum(pdf, 1e-30)
            bs.wo = dr.select(flip, -wo, wo)
            bs.pdf = dr.select(active, pdf, 0.0)
            bs.sampled_component = dr.select(pick_r, mi.UInt32(0), mi.UInt32(1))
            bs.sampled_type = dr.select(pick_r, mi.UInt32(+self.kinds[0]), mi.UInt32(+self.kinds[1]))
            return bs, dr.select(active, weight, mi.Color3f(0.0))

        def to_string(self):
            return f"GltfThinDielectric[eta={self.eta}, alpha={self.alpha}, specular_transmittance={self.transmittance}]"

    return RoughDielectric, ThinDielectric

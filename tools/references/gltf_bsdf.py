"""The glTF 2.0 metallic-roughness BRDF as a Mitsuba 3 BSDF plugin ("gltf_metal_rough").

The model is Appendix B of the glTF 2.0 specification, single scattering, with no energy
compensation (the model strata's `GltfBrdf::single_scattering()` evaluates). With base colour
b, metallic m, roughness r, wi the direction toward the viewer (Mitsuba's si.wi), wo the
direction toward the light (Mitsuba's wo), h = normalize(wi + wo), all in the shading frame:

    f0     = mix(0.04, b, m)                 (0.04: the reflectance of IOR 1.5)
    c_diff = b (1 - m)
    F      = f0 + (1 - f0) (1 - |wi.h|)^5    (Schlick)
    F_d    = 0.04 + 0.96 (1 - |wi.h|)^5      (the dielectric's)
    alpha  = r^2
    D      = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)                         (GGX)
    V      = 0.5 / (n.wo sqrt((n.wi)^2 (1 - alpha^2) + alpha^2)
                    + n.wi sqrt((n.wo)^2 (1 - alpha^2) + alpha^2))      (height-correlated)
    f      = (1 - F_d) c_diff / pi + F D V

which is the specification's normative mix(dielectric_brdf, metal_brdf, m) exactly (Schlick's F
is affine in f0, so the two specular lobes mix into one with f0 mixed; the diffuse lobe is the
dielectric's alone). The specification's "suggested simplification" weights the diffuse lobe by
1 - F instead, which agrees only at m = 0 and m = 1 (a white half-metal then returns 3/4 of the
light).

`eval` returns f (n.wo). Below alpha = 1e-3 the specular lobe is a perfect mirror: a delta
lobe of weight F(n.wi) that only `sample` produces (`eval` and `pdf` leave it out), as in strata.

The BSDF is two-sided: where si.wi lies below the shading frame's surface, the frame is mirrored
(both directions' z negated) before evaluating, as Mitsuba's `twosided` does, so both faces
show the same material.

Sampling uses Mitsuba's own tools, nothing shared with strata but the formula: the specular lobe
reflects wi about a normal drawn by `mi.MicrofacetDistribution(GGX, alpha, sample_visible=True)`
(density G1(wi) D(h) / (4 n.wi) in wo); the diffuse lobe draws wo with
`mi.warp.square_to_cosine_hemisphere`. The lobe is chosen with `sample1`: specular with
probability P = lum(F(n.wi)) / (lum(F(n.wi)) + lum((1 - F_d(n.wi)) c_diff)), lum the Rec. 709
luminance (each lobe's weight with the half vector taken as the normal; 1 where the diffuse lobe
is black; the choice only affects noise, never the expected value), diffuse with 1 - P. `pdf` is the mixture's density
P pdf_spec + (1 - P) pdf_cos, and a sample's weight is eval / pdf (the mirror's: F(n.wi) / P).
When the BSDFContext enables only one lobe (component 0 = specular, 1 = diffuse), P is 1 or 0.

Parameters (glTF's defaults):
- base_color: texture or RGB, linear (default 1): baseColorFactor x baseColorTexture;
- metallic: texture or float in [0, 1] (default 1), read with eval_1;
- roughness: texture or float in [0, 1] (default 1), perceptual (alpha = roughness^2).
Textures of metallic and roughness are single-channel (the converter splits glTF's
metallicRoughnessTexture: B = metallic, G = roughness). Values are clamped to [0, 1].

Variants: RGB ones (scalar_rgb, llvm_ad_rgb). Use:

    import mitsuba as mi; mi.set_variant("scalar_rgb")
    import gltf_bsdf; gltf_bsdf.register()
    mi.load_dict({"type": "gltf_metal_rough", "base_color": {"type": "rgb", "value": [1, .8, .3]},
                  "metallic": 1.0, "roughness": 0.4})
"""
import drjit as dr
import mitsuba as mi

PLUGIN_NAME = "gltf_metal_rough"
# Below this GGX alpha the specular lobe is a perfect mirror (strata: Ggx::SMOOTH_ALPHA).
SMOOTH_ALPHA = 1e-3
DIELECTRIC_F0 = 0.04  # the reflectance at normal incidence of IOR 1.5

_registered = set()


def register():
    """Registers the plugin in the current variant (once per variant)."""
    variant = mi.variant()
    if variant is None or not variant.endswith("_rgb"):
        raise RuntimeError(f"gltf_bsdf: needs an RGB variant (scalar_rgb, llvm_ad_rgb), not {variant}")
    if variant in _registered:
        return
    cls = _make_class()
    mi.register_bsdf(PLUGIN_NAME, lambda props: cls(props))
    _registered.add(variant)


def _uniform_value(tex):
    """The value of a texture that does not vary over the surface, else None."""
    if tex.is_spatially_varying():
        return None
    return _to_float(tex.mean())


def _to_float(x):
    """A Python float from a scalar variant's float or a JIT variant's one-entry array."""
    return float(x[0]) if dr.is_array_v(x) else float(x)


def _make_class():
    # Defined per variant: mi.BSDF and the array types are the current variant's.
    F = mi.BSDFFlags
    sides = F.FrontSide | F.BackSide

    def schlick(f0, cos):
        m = dr.clip(1.0 - cos, 0.0, 1.0)
        m2 = m * m
        return f0 + (1.0 - f0) * (m2 * m2 * m)

    def visibility(alpha, cos_i, cos_o):
        a2 = alpha * alpha
        denom = (cos_o * dr.sqrt(cos_i * cos_i * (1.0 - a2) + a2)
                 + cos_i * dr.sqrt(cos_o * cos_o * (1.0 - a2) + a2))
        return dr.select(denom > 0, 0.5 / dr.maximum(denom, 1e-30), 0.0)

    class GltfMetalRough(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.base_color = props.get_texture("base_color", 1.0)
            self.metallic = props.get_texture("metallic", 1.0)
            self.roughness = props.get_texture("roughness", 1.0)

            # Which lobes can occur. A texture's range is unknown (Mitsuba's bitmap has no
            # min or max): a textured roughness may give both specular kinds.
            r = _uniform_value(self.roughness)
            if r is None:
                self.may_be_glossy = self.may_be_delta = True
            else:
                r = min(max(r, 0.0), 1.0)
                self.may_be_glossy = r * r >= SMOOTH_ALPHA
                self.may_be_delta = not self.may_be_glossy
            m = _uniform_value(self.metallic)
            self.may_be_diffuse = (m is None or m < 1.0) and (
                self.base_color.is_spatially_varying() or _to_float(self.base_color.max()) > 0.0)

            spec = 0
            if self.may_be_glossy:
                spec |= +F.GlossyReflection
            if self.may_be_delta:
                spec |= +F.DeltaReflection
            components = [spec | +sides]
            if self.may_be_diffuse:
                components.append(+F.DiffuseReflection | +sides)
            if self.base_color.is_spatially_varying() or r is None or m is None:
                components = [c | +F.SpatiallyVarying for c in components]
            flags = 0
            for c in components:
                flags |= c
            self.m_components = components
            self.m_flags = flags

        # -- helpers --------------------------------------------------------------------

        def _material(self, si, active):
            """f0, c_diff and alpha at the shading point."""
            base = self.base_color.eval(si, active)
            metallic = dr.clip(self.metallic.eval_1(si, active), 0.0, 1.0)
            rough = dr.clip(self.roughness.eval_1(si, active), 0.0, 1.0)
            f0 = 0.04 + (base - 0.04) * metallic
            c_diff = base * (1.0 - metallic)
            return f0, c_diff, rough * rough

        def _lobes(self, ctx):
            """Which lobes the context enables (Python bools)."""
            glossy = self.may_be_glossy and ctx.is_enabled(F.GlossyReflection, 0)
            delta = self.may_be_delta and ctx.is_enabled(F.DeltaReflection, 0)
            diffuse = self.may_be_diffuse and ctx.is_enabled(F.DiffuseReflection, 1)
            return glossy, delta, diffuse

        @staticmethod
        def _specular_probability(f0, c_diff, cos_i, specular_on, diffuse_on):
            if not diffuse_on:
                return 1.0 if specular_on else 0.0
            if not specular_on:
                return 0.0
            fr = schlick(f0, cos_i)
            s = mi.luminance(fr)
            d = mi.luminance((1.0 - schlick(DIELECTRIC_F0, cos_i)) * c_diff)
            return dr.select(d <= 0.0, 1.0, s / dr.maximum(s + d, 1e-30))

        @staticmethod
        def _distribution(alpha):
            return mi.MicrofacetDistribution(mi.MicrofacetType.GGX, dr.maximum(alpha, SMOOTH_ALPHA), True)

        def _eval_pdf(self, ctx, si, wo, active):
            """(f cos, pdf) in the mirrored frame: wi = mirrored si.wi, wo mirrored the same."""
            glossy_on, delta_on, diffuse_on = self._lobes(ctx)
            flip = mi.Frame3f.cos_theta(si.wi) < 0.0
            wi = mi.Vector3f(si.wi.x, si.wi.y, dr.abs(si.wi.z))
            wo = mi.Vector3f(wo.x, wo.y, dr.select(flip, -wo.z, wo.z))
            cos_i, cos_o = wi.z, wo.z
            active = active & (cos_i > 0.0) & (cos_o > 0.0)

            f0, c_diff, alpha = self._material(si, active)
            glossy = alpha >= SMOOTH_ALPHA
            h = dr.normalize(wi + wo)
            fr = schlick(f0, dr.abs(dr.dot(wi, h)))
            distr = self._distribution(alpha)
            d = distr.eval(h)

            value = mi.Color3f(0.0)
            pdf = mi.Float(0.0)
            p_spec = self._specular_probability(f0, c_diff, cos_i, glossy_on or delta_on, diffuse_on)
            if diffuse_on:
                fr_d = schlick(DIELECTRIC_F0, dr.abs(dr.dot(wi, h)))
                value += (1.0 - fr_d) * c_diff * dr.inv_pi
                pdf += (1.0 - p_spec) * mi.warp.square_to_cosine_hemisphere_pdf(wo)
            if glossy_on:
                spec = fr * (d * visibility(alpha, cos_i, cos_o))
                value += dr.select(glossy, spec, 0.0)
                pdf += dr.select(glossy, p_spec * d * distr.smith_g1(wi, h) / (4.0 * dr.maximum(cos_i, 1e-30)), 0.0)
            value = dr.select(active, value * cos_o, 0.0)
            pdf = dr.select(active, pdf, 0.0)
            return value, pdf

        # -- the BSDF interface ---------------------------------------------------------

        def eval(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)[1]

        def eval_pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(ctx, si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            glossy_on, delta_on, diffuse_on = self._lobes(ctx)
            flip = mi.Frame3f.cos_theta(si.wi) < 0.0
            wi = mi.Vector3f(si.wi.x, si.wi.y, dr.abs(si.wi.z))
            cos_i = wi.z
            active = active & (cos_i > 0.0)

            f0, c_diff, alpha = self._material(si, active)
            # (Masks are combined with & and | only: in scalar variants they are Python bools.)
            glossy, smooth = alpha >= SMOOTH_ALPHA, alpha < SMOOTH_ALPHA
            p_spec = self._specular_probability(f0, c_diff, cos_i, glossy_on or delta_on, diffuse_on)
            pick_spec, pick_diffuse = sample1 < p_spec, sample1 >= p_spec
            # The specular lobe in the form this point has (glossy or mirror) must be enabled.
            active = active & (pick_diffuse | (glossy & glossy_on) | (smooth & delta_on))

            m, _ = self._distribution(alpha).sample(wi, sample2)
            wo_glossy = mi.reflect(wi, m)
            wo_mirror = mi.Vector3f(-wi.x, -wi.y, wi.z)
            wo_diffuse = mi.warp.square_to_cosine_hemisphere(sample2)
            mirror = pick_spec & smooth
            wo = dr.select(pick_spec, dr.select(glossy, wo_glossy, wo_mirror), wo_diffuse)
            wo_world = mi.Vector3f(wo.x, wo.y, dr.select(flip, -wo.z, wo.z))

            # Continuous lobes: the mixture's value and density at the direction drawn.
            value, pdf = self._eval_pdf(ctx, si, wo_world, active & (pick_diffuse | glossy))
            weight = dr.select(pdf > 0.0, value / dr.maximum(pdf, 1e-30), 0.0)
            # The mirror: weight F(n.wi) / P, probability P.
            mirror_pdf = dr.select(p_spec > 0.0, p_spec, 1.0)
            weight = dr.select(mirror, schlick(f0, cos_i) / mirror_pdf, weight)
            pdf = dr.select(mirror, p_spec, pdf)
            active = active & (wo.z > 0.0) & (pdf > 0.0)

            bs = mi.BSDFSample3f()
            bs.wo = wo_world
            bs.pdf = dr.select(active, pdf, 0.0)
            bs.eta = 1.0
            bs.sampled_component = dr.select(pick_spec, mi.UInt32(0), mi.UInt32(1))
            bs.sampled_type = dr.select(
                pick_spec,
                dr.select(glossy, mi.UInt32(+F.GlossyReflection), mi.UInt32(+F.DeltaReflection)),
                mi.UInt32(+F.DiffuseReflection))
            return bs, dr.select(active, weight, 0.0)

        def eval_diffuse_reflectance(self, si, active=True):
            _, c_diff, _ = self._material(si, active)
            return c_diff

        def to_string(self):
            return (f"GltfMetalRough[base_color={self.base_color}, metallic={self.metallic}, "
                    f"roughness={self.roughness}]")

    return GltfMetalRough


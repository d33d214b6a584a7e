#!/usr/bin/env python3
"""Checks of the clear-coat plugin (coat_bsdf.py, `gltf_coated`). Exits non-zero on failure.

    ~/.cache/strata/refs-venv/bin/python tools/references/check_coat_bsdf.py
    ... check_coat_bsdf.py --variants llvm_ad_rgb      # one variant only

For each variant:

- pointwise: eval and pdf against the model written out again here in numpy (float64): the
  extension's layering c Fc(n.wi) f_coat + (1 - c Fc(n.wi)) f_base with Fc Schlick's Fresnel of
  f0 0.04 at the view angle, f_coat = D V of GGX (height-correlated) and f_base the glTF BRDF
  (check_gltf_bsdf.model, itself written from glTF 2.0 Appendix B), and the documented mixture
  density; at fixed direction pairs (normal, oblique, grazing, back face) and at pairs the plugin
  samples, over coats of weight 1, 0.5 and 0.2 and roughness 0.3, 0.6 and 1 on four bases;
- a coat of weight 0 is its base exactly;
- sample weights: a continuous sample's weight is the formula's f cos / pdf at the direction
  drawn;
- the smooth coat: a mirror sample with probability c Fc and weight 1; over a smooth base the
  two mirrors together return c Fc + (1 - c Fc) F_base (stratified sample1, exact to 1/4096);
- white furnace: a white metal under a coat returns at most 1; under a smooth coat over a smooth
  white metal exactly 1; in JIT variants the sampled albedo equals the quadrature of eval (the
  sample weights integrate what eval says).

In JIT variants (mitsuba.chi2 needs one): chi-square tests of sampling against pdf for rough
coats (roughness 0.3 and 0.6, weight 1; 0.3 at weight 0.5) over a rough red dielectric and a
rough blue metal at incidence 0, 45 and 85 degrees, and negative controls: the chi-square test
must reject the pdf of a coat alpha 5% larger (85 degrees, where the coat takes 65% of the
samples, over both bases), of a coat roughness a third larger (normal incidence, where it takes
4%) and of the coat chosen with probability 1/2 instead of c Fc; and the pointwise comparison
must see the Fresnel term taken at wi.h instead of n.wi, a coat of f0 0.028 (index 1.4)
instead of 0.04, and the base not weighted by 1 - c Fc (these run in every variant; the plugin's
coat_f0 and attenuate_base, which make the reference's negative controls, must equal the formula
changed the same way).
"""
import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, HERE)

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

import check_gltf_bsdf as base_check  # noqa: E402
import coat_bsdf  # noqa: E402
import gltf_bsdf  # noqa: E402
from check_gltf_bsdf import direction, eval_pdf, is_jit  # noqa: E402

SMOOTH_ALPHA = 1e-3
# Bases: (name, base colour, metallic, roughness)
RED = ("red dielectric 0.5", (0.7, 0.06, 0.05), 0.0, 0.5)
BLUE_METAL = ("blue metal 0.6", (0.3, 0.5, 0.9), 1.0, 0.6)
GREEN_SMOOTH = ("smooth green dielectric", (0.08, 0.45, 0.15), 0.0, 0.0)
HALF_METAL = ("half metal 0.3", (0.9, 0.6, 0.3), 0.5, 0.3)
BASES = (RED, BLUE_METAL, GREEN_SMOOTH, HALF_METAL)
# Coats: (weight, roughness)
COATS = ((1.0, 0.3), (1.0, 0.6), (0.5, 0.3), (0.2, 1.0), (1.0, 0.0), (0.5, 0.0))


# ---------------------------------------------------------------------------------------
# the model, written out independently (numpy, float64)
# ---------------------------------------------------------------------------------------

def coat_model(coat, base, wi, wo, f0=0.04, fresnel_at_half=False, additive=False):
    """(f cos (N, 3), pdf (N,)) of a coat (weight c, roughness r) over `base` (name, colour,
    metallic, roughness), for direction pairs wi, wo (N, 3), both sides (the back face is the
    mirrored front face). The continuous lobes only: a smooth coat's mirror is not in eval.
    Negative controls, not the model: `fresnel_at_half`, the Fresnel term at wi.h; `additive`,
    the base not weighted by 1 - c Fc."""
    c, r = coat
    _, colour, metallic, roughness = base
    wi, wo = np.array(wi, dtype=np.float64), np.array(wo, dtype=np.float64)
    back = wi[:, 2] < 0
    wi[back, 2] *= -1
    wo[back, 2] *= -1
    ci, co = wi[:, 2], wo[:, 2]
    ok = (ci > 0) & (co > 0)
    h = wi + wo
    with np.errstate(invalid="ignore", divide="ignore"):
        h /= np.linalg.norm(h, axis=1, keepdims=True)
    alpha = r * r
    a2 = alpha * alpha
    cos_f = np.abs(np.sum(wi * h, axis=1)) if fresnel_at_half else ci
    w = c * (f0 + (1 - f0) * (1 - np.clip(cos_f, 0, 1)) ** 5)  # the coat's share
    p = c * (f0 + (1 - f0) * (1 - np.clip(ci, 0, 1)) ** 5)  # its sampling probability
    with np.errstate(invalid="ignore", divide="ignore"):  # h = 0 where wo = -wi (masked)
        f_base, pdf_base = base_check.model(colour, metallic, roughness, wi, wo)
    value = (1.0 if additive else (1 - w)[:, None]) * f_base
    pdf = (1 - p) * pdf_base
    if alpha >= SMOOTH_ALPHA:
        with np.errstate(invalid="ignore", divide="ignore"):
            d = a2 / (np.pi * (h[:, 2] ** 2 * (a2 - 1) + 1) ** 2)
            v = 0.5 / (co * np.sqrt(ci ** 2 * (1 - a2) + a2) + ci * np.sqrt(co ** 2 * (1 - a2) + a2))
            g1 = 2 * ci / (ci + np.sqrt(a2 * (1 - ci ** 2) + ci ** 2))
        value = value + np.where(ok, w * d * v * co, 0.0)[:, None]
        pdf = pdf + np.where(ok, p * d * g1 / (4 * ci), 0.0)
    return np.where(ok[:, None], value, 0.0), np.where(ok, pdf, 0.0)


def base_fresnel(base, ci):
    """The glTF BRDF's specular Fresnel at n.wi (its mirror's weight when smooth)."""
    _, colour, metallic, _ = base
    f0 = 0.04 * (1 - metallic) + np.asarray(colour) * metallic
    return f0 + (1 - f0) * (1 - ci) ** 5


# ---------------------------------------------------------------------------------------
# the plugin
# ---------------------------------------------------------------------------------------

def coat_dict(coat, base, f0=None, attenuate_base=None):
    _, colour, metallic, roughness = base
    d = {"type": coat_bsdf.PLUGIN_NAME, "clearcoat": float(coat[0]), "clearcoat_roughness": float(coat[1]),
         "base": {"type": gltf_bsdf.PLUGIN_NAME, "base_color": {"type": "rgb", "value": list(colour)},
                  "metallic": float(metallic), "roughness": float(roughness)}}
    if f0 is not None:
        d["coat_f0"] = f0
    if attenuate_base is not None:
        d["attenuate_base"] = attenuate_base
    return d


def plugin(coat, base, f0=None, attenuate_base=None):
    return mi.load_dict(coat_dict(coat, base, f0, attenuate_base))


def sample(bsdf, wi, u1, u2):
    """check_gltf_bsdf.sample with the sampled types as integers (flags)."""
    wo, w, pdf, kind = base_check.sample(bsdf, wi, u1, u2)
    return wo, w, pdf, np.asarray(kind).astype(np.int64)


def relative_error(a, b):
    return float(np.max(np.abs(a - b) / (np.abs(b) + 1e-6))) if len(a) else 0.0


def sampled_pairs(bsdf, rng, per_wi):
    """Direction pairs the plugin samples (continuous lobes), from both sides."""
    wis, wos = [], []
    for theta in (0.5, 20, 45, 70, 85, 180 - 10, 180 - 60):  # > 90: the back face
        wi = direction(theta, 30)
        wo, _, pdf, kind = sample(bsdf, wi, rng.uniform(size=per_wi), rng.uniform(size=(per_wi, 2)))
        keep = (pdf > 0) & ((kind & int(mi.BSDFFlags.Delta)) == 0)
        wis.append(np.repeat([wi], keep.sum(), axis=0))
        wos.append(wo[keep])
    return np.concatenate(wis), np.concatenate(wos)


# ---------------------------------------------------------------------------------------
# checks; each returns (ok, lines)
# ---------------------------------------------------------------------------------------

def check_pointwise():
    rng = np.random.default_rng(3)
    per = 256 if is_jit() else 8
    fixed_wi, fixed_wo = base_check.pair_set()
    worst_v = worst_p = 0.0
    n = 0
    for coat in COATS:
        for base in BASES:
            bsdf = plugin(coat, base)
            wi, wo = sampled_pairs(bsdf, rng, per)
            wi, wo = np.concatenate([fixed_wi, wi]), np.concatenate([fixed_wo, wo])
            value, pdf = eval_pdf(bsdf, wi, wo)
            ev, ep = coat_model(coat, base, wi, wo)
            worst_v = max(worst_v, relative_error(value, ev))
            worst_p = max(worst_p, relative_error(pdf, ep))
            n += len(wi)
    ok = worst_v < 2e-4 and worst_p < 2e-4
    return ok, [f"{'ok  ' if ok else 'FAIL'} pointwise: eval and pdf against the float64 formula, {len(COATS)} coats "
                f"x {len(BASES)} bases, {n} direction pairs (fixed and sampled, both sides): max relative error "
                f"eval {worst_v:.1e}, pdf {worst_p:.1e} (bound 2e-4)"]


def check_weightless_coat():
    wi, wo = base_check.pair_set()
    worst = 0.0
    for base in BASES:
        _, colour, metallic, roughness = base
        value, pdf = eval_pdf(plugin((0.0, 0.3), base), wi, wo)
        bv, bp = eval_pdf(base_check.plugin(colour, metallic, roughness), wi, wo)
        worst = max(worst, float(np.max(np.abs(value - bv))), float(np.max(np.abs(pdf - bp))))
    ok = worst == 0.0
    return ok, [f"{'ok  ' if ok else 'FAIL'} a coat of weight 0 is its base: max difference {worst:.1e} (must be 0)"]


def check_sample_weights():
    """A continuous sample's weight is the formula's f cos / pdf at its direction."""
    rng = np.random.default_rng(5)
    n = 4096 if is_jit() else 64
    worst = 0.0
    count = 0
    for coat in COATS:
        for base in BASES:
            bsdf = plugin(coat, base)
            for theta in (10, 50, 80, 180 - 40):
                wi = direction(theta, 70)
                wo, w, pdf, kind = sample(bsdf, wi, rng.uniform(size=n), rng.uniform(size=(n, 2)))
                keep = (pdf > 0) & ((kind & int(mi.BSDFFlags.Delta)) == 0)
                ev, ep = coat_model(coat, base, np.repeat([wi], keep.sum(), axis=0), wo[keep])
                expect = ev / np.maximum(ep, 1e-300)[:, None]
                worst = max(worst, relative_error(w[keep], expect), relative_error(pdf[keep], ep))
                count += int(keep.sum())
    ok = worst < 5e-4
    return ok, [f"{'ok  ' if ok else 'FAIL'} sample weights of the continuous lobes = formula f cos / pdf, and their "
                f"pdf = formula pdf, at {count} samples: max relative error {worst:.1e} (bound 5e-4)"]


def check_smooth_coat():
    lines, ok = [], True
    m = 4096
    u1 = (np.arange(m) + 0.5) / m
    u2 = np.random.default_rng(7).uniform(size=(m, 2))
    delta = int(mi.BSDFFlags.Delta)
    worst = 0.0
    for coat in ((1.0, 0.0), (0.5, 0.0)):
        for base in (RED, BLUE_METAL, GREEN_SMOOTH):
            bsdf = plugin(coat, base)
            for theta in (0, 40, 75, 180 - 30):
                wo, w, pdf, kind = sample(bsdf, direction(theta, 20), u1, u2)
                wi = np.array(direction(theta, 20))
                ci = abs(wi[2])
                share = coat[0] * (0.04 + 0.96 * (1 - ci) ** 5)
                mirror = np.array([-wi[0], -wi[1], wi[2]])
                is_delta = (kind & delta) != 0
                coat_pick = u1 < share
                good = bool(np.all(is_delta[coat_pick]) and np.allclose(wo[coat_pick], mirror, atol=1e-5)
                            and np.allclose(w[coat_pick], 1.0, rtol=1e-5)
                            and np.allclose(pdf[coat_pick], share, rtol=1e-5))
                # Both mirrors together return c Fc + (1 - c Fc) F_base (the base's only if smooth).
                total = (w * is_delta[:, None]).mean(axis=0)
                expect = share + ((1 - share) * base_fresnel(base, ci) if base[3] ** 2 < SMOOTH_ALPHA else 0.0)
                err = float(np.max(np.abs(total - expect)))
                worst = max(worst, err)
                good &= err <= 2.0 / m
                ok &= good
                if not good:
                    lines.append(f"FAIL smooth coat {coat} over {base[0]}, {theta} deg: mirror weight sum "
                                 f"{np.round(total, 5).tolist()}, expected {np.round(expect, 5).tolist()}")
    lines.append(f"{'ok  ' if ok else 'FAIL'} smooth coat: a mirror with probability c Fc and weight 1; with a smooth "
                 f"base the mirrors return c Fc + (1 - c Fc) F_base (max difference {worst:.1e}, {m} stratified "
                 "samples, weights 1 and 0.5, three bases, four incidences, both sides)")
    return ok, lines


def check_furnace():
    lines, ok = [], True
    white_rough = ("white metal 0.5", (1.0, 1.0, 1.0), 1.0, 0.5)
    white_smooth = ("white smooth metal", (1.0, 1.0, 1.0), 1.0, 0.0)
    n = 1 << 20 if is_jit() else 4000
    cases = [((1.0, 0.0), white_smooth), ((1.0, 0.3), white_rough), ((1.0, 1.0), white_rough),
             ((0.5, 0.6), white_rough)]
    for coat, base in cases:
        bsdf = plugin(coat, base)
        for theta in (0, 60, 85):
            mean, se = base_check.furnace_by_sampling(bsdf, theta, n)
            good = mean <= 1.0 + 4 * se
            extra = ""
            if base is white_smooth:
                good &= abs(mean - 1.0) < 1e-5
                extra = " (exactly 1: two mirrors of total weight c Fc + (1 - c Fc))"
            elif is_jit():
                quad = base_check.furnace_by_quadrature(bsdf, theta)
                good &= abs(quad - mean) <= 4 * se + 2e-3
                extra = f", quadrature of eval {quad:.4f}"
            ok &= bool(good)
            lines.append(f"{'ok  ' if good else 'FAIL'} furnace, coat {coat} over {base[0]}, {theta} deg: albedo "
                         f"{mean:.4f} +- {se:.4f}{extra}")
    return ok, lines


def check_model_controls():
    """The pointwise comparison sees a wrong model: the Fresnel term at wi.h, a coat of f0 0.028."""
    lines, ok = [], True
    rng = np.random.default_rng(19)
    per = 256 if is_jit() else 16
    coat, base = (1.0, 0.3), RED
    bsdf = plugin(coat, base)
    wi, wo = sampled_pairs(bsdf, rng, per)
    value, _ = eval_pdf(bsdf, wi, wo)
    wrong, _ = coat_model(coat, base, wi, wo, fresnel_at_half=True)
    e = relative_error(value, wrong)
    good = e > 0.01
    ok &= good
    lines.append(f"{'ok  ' if good else 'FAIL'} negative control, the coat's Fresnel at wi.h instead of n.wi (coat 0.3 "
                 f"over the red dielectric): max relative difference {e:.2f} (must exceed 0.01)")
    f0_plugin, _ = eval_pdf(plugin(coat, base, f0=0.028), wi, wo)
    e = relative_error(f0_plugin, coat_model(coat, base, wi, wo)[0])
    good = e > 0.01
    ok &= good
    lines.append(f"{'ok  ' if good else 'FAIL'} negative control, coat_f0 0.028 (index 1.4) against the formula's "
                 f"0.04: max relative difference {e:.2f} (must exceed 0.01)")
    e = relative_error(f0_plugin, coat_model(coat, base, wi, wo, f0=0.028)[0])
    good = e < 2e-4
    ok &= good
    lines.append(f"{'ok  ' if good else 'FAIL'} coat_f0 0.028 against the formula with f0 0.028: max relative error "
                 f"{e:.1e} (bound 2e-4)")
    additive, _ = eval_pdf(plugin(coat, base, attenuate_base=False), wi, wo)
    e = relative_error(additive, coat_model(coat, base, wi, wo)[0])
    good = e > 0.01
    ok &= good
    lines.append(f"{'ok  ' if good else 'FAIL'} negative control, attenuate_base false (the base not weighted by "
                 f"1 - c Fc) against the formula: max relative difference {e:.2f} (must exceed 0.01)")
    e = relative_error(additive, coat_model(coat, base, wi, wo, additive=True)[0])
    good = e < 2e-4
    ok &= good
    lines.append(f"{'ok  ' if good else 'FAIL'} attenuate_base false against the additive formula: max relative "
                 f"error {e:.1e} (bound 2e-4)")
    return ok, lines


# ---------------------------------------------------------------------------------------
# chi-square tests (JIT variants)
# ---------------------------------------------------------------------------------------

CHI2_COATS = ((1.0, 0.3), (1.0, 0.6))
CHI2_BASES = (RED, BLUE_METAL)
CHI2_THETA = (0, 45, 85)
CHI2_EXTRA = (((0.5, 0.3), RED, 45), ((0.5, 0.3), BLUE_METAL, 85))
CHI2_SIGNIFICANCE = 0.01


def chi2_test(sample_func, pdf_func, coat_roughness, theta, test_count):
    """mitsuba.chi2 on the whole sphere with check_gltf_bsdf's grids: the fine grid for a coat of
    roughness 0.3 (alpha 0.09, a lobe as sharp as the base tests' roughness 0.1 and 0.3) or
    grazing incidence, and at normal incidence SphericalDomain's pole turned onto +y (the coat's
    lobe peaks at +z, where the trapezoid rule over-integrates the cells around the pole)."""
    from mitsuba.chi2 import ChiSquareTest, SphericalDomain
    res, ires = base_check.chi2_grid(coat_roughness - 0.05, theta)
    domain = base_check.RotatedSphericalDomain() if theta == 0 else SphericalDomain()
    test = ChiSquareTest(domain=domain, sample_func=sample_func, pdf_func=pdf_func, sample_dim=3,
                         sample_count=1_000_000, res=res, ires=ires, seed=1)
    accepted = test.run(CHI2_SIGNIFICANCE, test_count, quiet=True)
    return accepted, test


def check_chi2():
    from mitsuba.chi2 import BSDFAdapter
    lines, ok = [], True
    cases = [(c, b, t) for c in CHI2_COATS for b in CHI2_BASES for t in CHI2_THETA] + list(CHI2_EXTRA)
    table = []
    for coat, base, theta in cases:
        s, p = BSDFAdapter(coat_bsdf.PLUGIN_NAME, coat_dict(coat, base), wi=direction(theta, 0))
        accepted, test = chi2_test(s, p, coat[1], theta, len(cases))
        ok &= bool(accepted)
        table.append(f"coat {coat} over {base[0]}, {theta} deg: p {test.p_value:.3f}"
                     + ("" if accepted else " REJECTED"))
        if not accepted:
            lines.append(f"FAIL chi2 {table[-1]}:\n{test.messages}")
    significance = 1 - (1 - CHI2_SIGNIFICANCE) ** (1 / len(cases))
    lines.append(f"{'ok  ' if ok else 'FAIL'} chi2: {sum('REJECTED' not in t for t in table)}/{len(cases)} accepted at "
                 f"significance {CHI2_SIGNIFICANCE} (Sidak-corrected per test: {significance:.2e})")
    lines += ["     " + t for t in table]
    return ok, lines


def check_chi2_controls():
    from mitsuba.chi2 import BSDFAdapter
    lines, ok = [], True
    controls = []
    # The coat's roughness off: at grazing incidence, where the coat takes most samples (c Fc 0.65
    # at 85 deg), an alpha 5% larger; at normal incidence, where it takes 4% of them, a roughness a
    # third larger (there a roughness 20% larger gives p = 0.008 over the red dielectric, 0.018 over
    # the blue metal, whose own lobe overlaps the coat's: too close to the significance to be a
    # control).
    for base, theta, rough, what in ((RED, 85, 0.3 * math.sqrt(1.05), "alpha 5% larger"),
                                     (BLUE_METAL, 85, 0.3 * math.sqrt(1.05), "alpha 5% larger"),
                                     (RED, 0, 0.4, "roughness a third larger")):
        s, _ = BSDFAdapter(coat_bsdf.PLUGIN_NAME, coat_dict((1.0, 0.3), base), wi=direction(theta, 0))
        _, p_wrong = BSDFAdapter(coat_bsdf.PLUGIN_NAME, coat_dict((1.0, rough), base), wi=direction(theta, 0))
        controls.append((f"coat 0.3 over {base[0]}, {theta} deg: pdf of a coat {what}", s, p_wrong, theta))

    # The coat chosen with probability 1/2 instead of P = c Fc (over the red dielectric, 45 deg).
    wi = direction(45, 0)
    s, _ = BSDFAdapter(coat_bsdf.PLUGIN_NAME, coat_dict((1.0, 0.3), RED), wi=wi)
    _, p_base_only = BSDFAdapter(gltf_bsdf.PLUGIN_NAME, coat_dict((1.0, 0.3), RED)["base"], wi=wi)
    share = 0.04 + 0.96 * (1 - wi[2]) ** 5
    distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, 0.09, True)
    wi_v = mi.Vector3f(*wi)

    def p_half(wo):
        h = dr.normalize(wi_v + wo)
        coat = distr.eval(h) * distr.smith_g1(wi_v, h) / (4 * wi_v.z)
        return dr.select(wo.z > 0, 0.5 * coat, 0.0) + 0.5 * p_base_only(wo)

    controls.append((f"coat 0.3 over the red dielectric, 45 deg: the coat chosen with probability 1/2 instead of "
                     f"c Fc = {share:.3f}", s, p_half, 45))
    for what, sf, pf, theta in controls:
        accepted, test = chi2_test(sf, pf, 0.3, theta, 1)
        good = not accepted
        ok &= good
        lines.append(f"{'ok  ' if good else 'FAIL'} negative control, {what}: "
                     f"{'accepted (wrongly)' if accepted else 'rejected'}, p-value {test.p_value:.2e}")
    return ok, lines


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variants", default="scalar_rgb,llvm_ad_rgb",
                    help="comma-separated Mitsuba variants (default scalar_rgb,llvm_ad_rgb; chi2 needs a JIT one)")
    args = ap.parse_args()
    all_ok, ran_chi2 = True, False
    for variant in args.variants.split(","):
        try:
            mi.set_variant(variant)
        except Exception as e:  # e.g. llvm_ad_rgb without a usable libLLVM
            print(f"FAIL variant {variant} unavailable: {e} (llvm_ad_rgb needs Debian's libllvm19)")
            all_ok = False
            continue
        gltf_bsdf.register()
        coat_bsdf.register()
        print(f"== {variant}", flush=True)
        checks = [check_pointwise, check_weightless_coat, check_sample_weights, check_smooth_coat, check_furnace,
                  check_model_controls]
        if is_jit():
            checks += [check_chi2, check_chi2_controls]
            ran_chi2 = True
        for check in checks:
            ok, lines = check()
            all_ok &= ok
            print("\n".join(lines), flush=True)
    if not ran_chi2:
        print("FAIL no JIT variant ran: the chi-square tests did not run")
        all_ok = False
    print("checks:", "passed" if all_ok else "FAILED")
    return 0 if all_ok else 1


if __name__ == "__main__":
    sys.exit(main())

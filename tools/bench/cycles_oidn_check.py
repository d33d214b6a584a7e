"""Does this Blender's Cycles have Open Image Denoise? (issue 30)

    blender -b --factory-startup -P tools/bench/cycles_oidn_check.py

Prints _cycles.with_openimagedenoise, the denoiser enum, and what a 64x48, 4-spp render with
use_denoising = True and denoiser = OPENIMAGEDENOISE does. Debian 12's Blender 3.4.1: built
without OIDN (the enum is empty; the render fails with "Build without OpenImageDenoiser").
"""
import bpy, sys, time
sc = bpy.context.scene
sc.render.engine = 'CYCLES'
print("CYCLES_VERSION", bpy.app.version_string)
try:
    import _cycles
    print("WITH_OIDN (_cycles.with_openimagedenoise):", getattr(_cycles, "with_openimagedenoise", "n/a"))
    print("WITH_OPTIX:", getattr(_cycles, "with_optix", "n/a"))
except Exception as e:
    print("import _cycles failed:", e)
prop = type(sc.cycles).bl_rna.properties['denoiser']
print("denoiser enum items:", [i.identifier for i in prop.enum_items])
sc.cycles.samples = 4
sc.cycles.device = 'CPU'
sc.render.resolution_x = 64; sc.render.resolution_y = 48; sc.render.resolution_percentage = 100
sc.cycles.use_denoising = True
try:
    sc.cycles.denoiser = 'OPENIMAGEDENOISE'
    print("set denoiser ->", sc.cycles.denoiser)
except Exception as e:
    print("setting denoiser failed:", repr(e))
print("use_denoising =", sc.cycles.use_denoising, "denoiser =", sc.cycles.denoiser)
sc.render.filepath = "/tmp/cycles_oidn_check.png"
t = time.time()
try:
    bpy.ops.render.render(write_still=True)
    print("RENDER OK in", time.time() - t)
except Exception as e:
    print("render failed:", repr(e))

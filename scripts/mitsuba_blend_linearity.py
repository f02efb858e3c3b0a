import mitsuba as mi, numpy as np
mi.set_variant("scalar_rgb")
def scene(bsdf):
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 2},
        "sensor": {"type": "perspective", "fov": 40, "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0.9, 2.6], target=[0, 0.45, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 24, "height": 18, "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": 256}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.4, 0.45, 0.5]}},
        "ball": {"type": "sphere", "center": [0, 0.5, 0], "radius": 0.5, "bsdf": bsdf},
    })
rough = {"type": "roughplastic", "distribution": "ggx", "alpha": 0.3, "diffuse_reflectance": {"type": "rgb", "value": [0.05, 0.1, 0.4]}}
gold = {"type": "conductor", "material": "Au"}
res = {}
for name, b in [("rough", rough), ("gold", gold), ("blend", {"type": "blendbsdf", "weight": 0.5, "a": rough, "b": gold})]:
    s = scene(b)
    vals = [float(np.mean(np.array(mi.render(s, seed=k)))) for k in range(8)]
    res[name] = (np.mean(vals), np.std(vals) / np.sqrt(len(vals)))
    print(name, res[name])
lin = 0.5 * res["rough"][0] + 0.5 * res["gold"][0]
print("blend", res["blend"][0], "linear", lin, "ratio", res["blend"][0] / lin)

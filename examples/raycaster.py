"""A minimal external renderer for the suite's renderer protocol (docs/renderers.md).

    python3 examples/raycaster.py JOB.json

It imports nothing of the suite (only numpy and OpenEXR), to show that a
renderer in any language can be measured: it reads the job file and the
scene's glTF, renders progressively and writes ``step-<N>.exr`` for every
checkpoint and ``timings.json``.

What it renders: one jittered camera ray per pixel and step; at the nearest
triangle, the direct light of the rectangular area lights, one uniformly
sampled point per light with a shadow ray, for a Lambertian surface of the
material's base colour; emission; lights seen directly; the environment where
rays leave the scene. What it leaves out, on purpose (the suite measures the
bias this leaves against the path-traced ground truth): indirect light,
specular reflection (metallic and roughness are ignored), textures and light
from the environment on surfaces.
"""

from __future__ import annotations

import base64
import json
import os
import sys
import time

import numpy as np
import OpenEXR


def fail(message: str) -> None:
    print(f"raycaster: {message}", file=sys.stderr)
    sys.exit(2)


def load_triangles(path: str):
    """World-space triangles (T, 3, 3), per-triangle albedo and emission (T, 3) of a job's glTF."""
    doc = json.load(open(path, encoding="utf-8"))
    (buf,) = doc["buffers"]
    data = base64.b64decode(buf["uri"].split(",", 1)[1])
    kinds = {5126: np.float32, 5123: np.uint16, 5125: np.uint32}
    sizes = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}

    def accessor(i):
        a = doc["accessors"][i]
        view = doc["bufferViews"][a["bufferView"]]
        start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
        n = a["count"] * sizes[a["type"]]
        return np.frombuffer(data, kinds[a["componentType"]], n, start).reshape(a["count"], -1)

    tris, albedo, emission = [], [], []
    for mesh in doc["meshes"]:
        for prim in mesh["primitives"]:
            pos = accessor(prim["attributes"]["POSITION"]).astype(np.float64)
            idx = accessor(prim["indices"]).reshape(-1, 3)
            m = doc["materials"][prim["material"]]
            strength = m.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
            tris.append(pos[idx])
            albedo.append(np.tile(m["pbrMetallicRoughness"]["baseColorFactor"][:3], (len(idx), 1)))
            emission.append(np.tile(np.multiply(m.get("emissiveFactor", [0, 0, 0]), strength), (len(idx), 1)))
    return np.concatenate(tris), np.concatenate(albedo), np.concatenate(emission)


def intersect(origins, dirs, tris, t_max=None, chunk=4096):
    """Nearest hit (t, triangle index) of rays (N, 3) with triangles (T, 3, 3); Möller–Trumbore, both sides.

    Rays go in chunks: the rays × triangles arrays stay small whatever the image size."""
    if len(origins) > chunk:
        parts = [intersect(origins[i:i + chunk], dirs[i:i + chunk], tris,
                           None if t_max is None else t_max[i:i + chunk], chunk) for i in range(0, len(origins), chunk)]
        return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
    v0, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    p = np.cross(dirs[:, None, :], e2[None])
    det = np.einsum("ntk,tk->nt", p, e1)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = origins[:, None, :] - v0[None]
    u = np.einsum("ntk,ntk->nt", s, p) * inv
    q = np.cross(s, e1[None])
    v = np.einsum("nk,ntk->nt", dirs, q) * inv
    t = np.einsum("ntk,tk->nt", q, e2) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-6)
    if t_max is not None:
        hit &= t < t_max[:, None]
    t = np.where(hit, t, np.inf)
    k = np.argmin(t, axis=1)
    return t[np.arange(len(k)), k], k


def environment_lookup(env, dirs):
    if env is None:
        return np.zeros_like(dirs)
    c, s = np.cos(np.radians(env["rotation_deg"])), np.sin(np.radians(env["rotation_deg"]))
    d = dirs @ np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])  # R^-1 d for row vectors
    img = env["image"]
    u = (np.arctan2(d[:, 0], -d[:, 2]) / (2 * np.pi)) % 1.0
    v = np.arccos(np.clip(d[:, 1], -1, 1)) / np.pi
    h, w = img.shape[:2]
    return img[np.minimum((v * h).astype(int), h - 1), np.minimum((u * w).astype(int), w - 1)] * env["intensity"]


def write_exr(path: str, image: np.ndarray) -> None:
    tmp = path + ".part.exr"
    channels = {c: np.ascontiguousarray(image[..., i], dtype=np.float32) for i, c in enumerate("RGB")}
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, channels).write(tmp)
    os.replace(tmp, path)  # a stopped renderer leaves no half-written checkpoint


def main(job_path: str) -> None:
    t0 = time.perf_counter()
    try:
        job = json.load(open(job_path, encoding="utf-8"))
    except (OSError, ValueError) as exc:
        fail(f"{job_path}: cannot read the job: {exc}")
    if job.get("schema") != 1:
        fail(f"{job_path}: job schema {job.get('schema')!r}; this renderer reads schema 1")
    scene, cam, out = job["scene"], job["camera"], job["output_dir"]
    tris, albedo, emission = load_triangles(scene["gltf"])
    lights = scene["lights"]
    env = scene["environment"]
    if env is not None:
        f = OpenEXR.File(env["file"]).channels()
        rgb = f["RGB"].pixels if "RGB" in f else np.stack([f[c].pixels for c in "RGB"], axis=-1)
        env = {**env, "image": np.asarray(rgb, dtype=np.float64)}
    w, h = cam["width"], cam["height"]
    fwd = np.subtract(cam["target"], cam["position"]).astype(np.float64)
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, cam["up"])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    tan = np.tan(np.radians(cam["fov_deg"]) / 2)
    light_tris = np.array([[l["corners"][0], l["corners"][1], l["corners"][2]] for l in lights] +
                          [[l["corners"][0], l["corners"][2], l["corners"][3]] for l in lights]).reshape(-1, 3, 3)
    setup = time.perf_counter() - t0

    acc = np.zeros((h * w, 3))
    seconds, elapsed = {}, 0.0
    ys, xs = np.mgrid[0:h, 0:w].reshape(2, -1).astype(np.float64)
    origin = np.tile(np.asarray(cam["position"], dtype=np.float64), (h * w, 1))
    for step in range(1, job["checkpoints"][-1] + 1):
        t1 = time.perf_counter()
        rng = np.random.default_rng(job["seed"] * 100003 + step)
        jx, jy = rng.random(h * w), rng.random(h * w)
        sx = (2 * (xs + jx) / w - 1) * tan * w / h
        sy = (1 - 2 * (ys + jy) / h) * tan
        d = fwd + sx[:, None] * right + sy[:, None] * up
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        t, k = intersect(origin, d, tris)
        radiance = np.zeros((h * w, 3))
        miss = ~np.isfinite(t)
        radiance[miss] = environment_lookup(env, d[miss])
        if len(light_tris):  # lights seen directly, from their front
            tl, kl = intersect(origin, d, light_tris)
            li = kl % max(len(lights), 1)
            normals = np.array([l["normal"] for l in lights])[li]
            front = np.isfinite(tl) & (tl < t) & (np.einsum("nk,nk->n", normals, d) < 0)
            radiance[front] = np.array([l["radiance"] for l in lights])[li[front]]
        else:
            front = np.zeros(h * w, bool)
        hit = ~miss & ~front
        p = origin[hit] + t[hit, None] * d[hit]
        tri = tris[k[hit]]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        n *= -np.sign(np.einsum("nk,nk->n", n, d[hit]))[:, None]  # face the viewer
        colour = emission[k[hit]].copy()
        for light in lights:  # one point per light: L · f · cosθ · cosθ' · A / r²
            a, b = rng.random(len(p)), rng.random(len(p))
            c = np.asarray(light["corners"], dtype=np.float64)
            q = c[0] + a[:, None] * (c[1] - c[0]) + b[:, None] * (c[3] - c[0])
            to = q - p
            dist = np.linalg.norm(to, axis=1)
            wi = to / dist[:, None]
            cos_s = np.clip(np.einsum("nk,nk->n", n, wi), 0, None)
            cos_l = np.clip(-wi @ np.asarray(light["normal"], dtype=np.float64), 0, None)
            ts, _ = intersect(p + 1e-5 * n, wi, tris, t_max=dist * (1 - 1e-4))
            visible = ~np.isfinite(ts)
            area = light["size"][0] * light["size"][1]
            g = cos_s * cos_l * area / np.maximum(dist, 1e-6) ** 2 * visible
            colour += albedo[k[hit]] / np.pi * np.asarray(light["radiance"]) * g[:, None]
        radiance[hit] = colour
        acc += radiance
        elapsed += time.perf_counter() - t1
        if step in job["checkpoints"]:
            seconds[str(step)] = elapsed
            write_exr(os.path.join(out, f"step-{step}.exr"), (acc / step).reshape(h, w, 3))
    timings = {"setup_seconds": setup, "seconds": seconds,
               "metadata": {"method": "numpy ray caster, direct light, diffuse", "triangles": int(len(tris))}}
    tmp = os.path.join(out, "timings.json.part")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(timings, f)
    os.replace(tmp, os.path.join(out, "timings.json"))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        fail("usage: raycaster.py JOB.json")
    main(sys.argv[1])

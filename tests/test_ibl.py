"""Environment preprocessing (compare.ibl) and environment lighting in the rasterizer.

Preprocessing is checked against brute-force sums (prefilter, irradiance, SH9),
the shared BRDF's own albedo (split-sum LUT) and constants; the GLSL mappings
against numpy; the rasterizer against closed forms (furnaces) and against
Mitsuba (mirror sphere, concave corner).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare.brdf import alpha_from_roughness, directional_albedo, ggx_d
from compare.scene.procedural_env import procedural_map
from compare.scene.equirect import sample_equirect
from compare.ibl import IBL_VERSION, preprocess, split_sum
from compare.ibl.atlas import build_atlas, sample_levels
from compare.ibl.cubemap import face_coordinates, padded_directions, sample_faces, texel_solid_angles
from compare.ibl.irradiance import irradiance_at, sh9_irradiance, sh9_project
from compare.ibl.lut import split_sum_lut
from compare.ibl.prefilter import level_sizes, prefilter, source_chain
from compare.scene.loader import parse_scene
from tests.helpers import CORNELL, ROOT


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))


def unit_vectors(n: int, seed: int = 0) -> np.ndarray:
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def smooth_map(width: int = 64) -> np.ndarray:
    """A smooth, asymmetric equirectangular map (no sun): a sky without its disk."""
    return procedural_map("sky", {"width": width, "sun_radiance": 0.0, "glow": 3.0})


# ----------------------------------------------------------------------------- cube maps


def test_cube_faces_round_trip_and_solid_angles():
    size = 8
    d = padded_directions(size, padded=False)
    face, s, t = face_coordinates(d.reshape(-1, 3))
    k = (np.arange(size) + 0.5) / size * 2 - 1
    np.testing.assert_array_equal(face.reshape(6, size, size), np.arange(6)[:, None, None] * np.ones((size, size)))
    np.testing.assert_allclose(s.reshape(6, size, size), np.broadcast_to(k[None, None, :], (6, size, size)))
    np.testing.assert_allclose(t.reshape(6, size, size), np.broadcast_to(k[None, :, None], (6, size, size)))
    assert 6 * texel_solid_angles(size).sum() == pytest.approx(4 * math.pi, rel=1e-12)
    # OpenGL's table: +X face, s grows towards -Z, t towards -Y.
    face, s, t = face_coordinates(np.array([[1.0, -0.5, -0.5]]))
    assert (face[0], s[0], t[0]) == (0, 0.5, 0.5)


def test_padded_lookup_is_seamless():
    """Lookups across face edges are as accurate as inside: the border holds the neighbour's values."""
    a = np.array([0.2, 0.7, -0.4])
    chain = source_chain(np.zeros((4, 8, 3), np.float32), 16)  # shape only
    d = padded_directions(16)
    level = (d @ a)[..., None] + 1.0
    q = unit_vectors(20000)
    got = sample_faces(level, q)[:, 0]
    exact = q @ a + 1.0
    _, s, t = face_coordinates(q)
    edge = np.maximum(np.abs(s), np.abs(t)) > 1 - 1 / 16
    assert np.abs(got - exact)[edge].max() < 2.5 * np.abs(got - exact)[~edge].max()
    assert len(chain) == 5  # 16, 8, 4, 2, 1


def test_source_chain_samples_the_map_as_mitsuba_does():
    img = smooth_map(128)
    chain = source_chain(img, 32)
    d = padded_directions(32)
    np.testing.assert_allclose(chain[0][:, 5, 7], sample_equirect(img, d[:, 5, 7]), rtol=0.02)
    # Each level is the solid-angle-weighted mean of the one above: the total power is kept.
    power = [np.einsum("fijc,ij->c", c[:, 1:-1, 1:-1], texel_solid_angles(c.shape[1] - 2)) for c in chain]
    np.testing.assert_allclose(power, np.broadcast_to(power[0], (len(power), 3)), rtol=1e-9)


# ----------------------------------------------------------------------------- prefilter, irradiance, SH9


def brute_prefilter(level: np.ndarray, n: np.ndarray, roughness: float) -> np.ndarray:
    """Karis' prefilter integral by a sum over every source texel: ∫ L D(h)/4 (n·l) dl / ∫ D(h)/4 (n·l) dl."""
    size = level.shape[1] - 2
    dirs = padded_directions(size, padded=False).reshape(-1, 3)
    rad = level[:, 1:-1, 1:-1].reshape(-1, 3)
    omega = np.broadcast_to(texel_solid_angles(size), (6, size, size)).reshape(-1)
    alpha = alpha_from_roughness(roughness)
    out = []
    for nn in n:
        nl = dirs @ nn
        h = dirs + nn
        h /= np.linalg.norm(h, axis=1, keepdims=True)
        w = np.where(nl > 0, ggx_d(np.clip(h @ nn, 0, 1), alpha) / 4 * nl * omega, 0.0)
        out.append((rad * w[:, None]).sum(0) / w.sum())
    return np.array(out)


@pytest.mark.parametrize("roughness", [0.25, 0.5, 1.0])
def test_prefilter_matches_brute_force(roughness):
    chain = source_chain(smooth_map(128), 32)
    n = unit_vectors(24, seed=4)
    got = prefilter(chain, n, roughness, 512)
    exact = brute_prefilter(chain[0], n, roughness)
    rel = np.abs(got - exact) / exact
    print(f"prefilter roughness {roughness}: relative error mean {rel.mean():.4f}, max {rel.max():.4f}")
    # The pdf-based source level (K = 4) trades noise for blur: small on average, a few per cent
    # where the lobe meets the horizon's edge (measured: mean <= 1.2 %, max 8 % at roughness 1).
    assert rel.mean() < 0.015
    assert rel.max() < 0.1


def test_prefilter_keeps_a_constant_and_the_chain_layout():
    ibl = preprocess(np.full((8, 16, 3), 2.5, np.float32), size=16, samples=32, cache_dir=False)
    assert len(ibl.radiance) == 9 and list(ibl.roughness) == pytest.approx([i / 8 for i in range(9)])
    assert [r.shape[1] - 2 for r in ibl.radiance] == level_sizes(16, 9) == [16, 8, 8, 8, 8, 8, 8, 8, 8]
    for r in ibl.radiance:
        np.testing.assert_allclose(r, 2.5, rtol=1e-5)
    np.testing.assert_allclose(ibl.irradiance, 2.5 * math.pi, rtol=1e-3)
    np.testing.assert_allclose(sh9_irradiance(ibl.sh9, unit_vectors(10)), 2.5 * math.pi, rtol=1e-5)


def test_sh9_is_exact_for_quadratic_radiance():
    d = padded_directions(32)
    radiance = (1.0 + 0.5 * d[..., 0] + 0.3 * d[..., 1] * d[..., 2] + 0.2 * d[..., 2] ** 2)[..., None]
    n = unit_vectors(50, seed=5)
    np.testing.assert_allclose(sh9_irradiance(sh9_project(radiance), n), irradiance_at(radiance, n), rtol=2e-3)


def test_sh9_rings_with_a_sun_and_the_cube_does_not():
    chain = source_chain(procedural_map("sky", {"width": 256, "sun_size": 3.0}), 32)
    n = unit_vectors(200, seed=6)
    exact = irradiance_at(chain[0], n)
    ibl_cube = irradiance_at(chain[1], n)  # a coarser source, as the convolved cube uses
    sh = sh9_irradiance(sh9_project(chain[0]), n)
    err_cube = np.abs(ibl_cube - exact).mean() / exact.mean()
    err_sh = np.abs(sh - exact).mean() / exact.mean()
    print(f"irradiance with a sun: cube {err_cube:.4f}, SH9 {err_sh:.4f} (mean relative error)")
    assert err_cube < 0.01 and err_sh > 5 * err_cube


# ----------------------------------------------------------------------------- split-sum LUT


def test_lut_reproduces_the_shared_brdf_albedo():
    lut = split_sum_lut(8, 256)
    c = (np.arange(8) + 0.5) / 8
    for j in (0, 3, 7):
        for i in (1, 4, 7):
            a, b, cd = lut[j, i]
            metal = directional_albedo(c[j], c[i], (1, 1, 1), 1.0, 4096)[0]
            dark = directional_albedo(c[j], c[i], (0, 0, 0), 0.0, 4096)[0]  # F0 = 0.04, no diffuse
            white = directional_albedo(c[j], c[i], (1, 1, 1), 0.0, 4096)[0]
            assert a + b == pytest.approx(metal, abs=0.01)
            assert 0.04 * a + b == pytest.approx(dark, abs=0.005)
            assert 0.04 * a + b + cd == pytest.approx(white, abs=0.01)


def test_split_sum_lut_is_cached(tmp_path):
    t1, seconds, cached = split_sum(8, 64, cache_dir=tmp_path)
    t2, seconds2, cached2 = split_sum(8, 64, cache_dir=tmp_path)
    assert not cached and cached2 and seconds2 == seconds
    np.testing.assert_array_equal(t1, t2)


# ----------------------------------------------------------------------------- the cache


def test_preprocess_cache_by_content(tmp_path):
    img = smooth_map(32)
    a = preprocess(img, size=8, samples=16, cache_dir=tmp_path)
    b = preprocess(img, size=8, samples=16, cache_dir=tmp_path)
    assert not a.cached and b.cached and a.key == b.key and b.timings == a.timings
    for x, y in zip(a.radiance, b.radiance):
        np.testing.assert_array_equal(x, y)
    files = list((tmp_path / "ibl").rglob("*.npz"))
    assert [f.stem for f in files] == [a.key]
    other = img.copy()
    other[0, 0] += 1
    assert preprocess(other, size=8, samples=16, cache_dir=tmp_path).key != a.key
    assert preprocess(img, size=8, samples=32, cache_dir=tmp_path).key != a.key
    # A damaged entry is recomputed, not trusted.
    files[0].write_bytes(b"garbage")
    c = preprocess(img, size=8, samples=16, cache_dir=tmp_path)
    assert not c.cached and c.key == a.key
    assert IBL_VERSION >= 1


def test_preprocess_rejects_bad_input():
    with pytest.raises(ValueError, match="size: expected a power of two"):
        preprocess(smooth_map(32), size=12, cache_dir=False)
    with pytest.raises(ValueError, match="non-negative"):
        preprocess(-smooth_map(32), cache_dir=False)


def test_atlas_layouts():
    ibl = preprocess(smooth_map(32), size=8, samples=16, octahedral=True, cache_dir=False)
    cube = build_atlas(ibl.radiance)
    assert cube.data.shape == (10 + 8 * 10, 6 * 10, 3) and cube.levels[1].tolist() == [0, 10, 8]
    np.testing.assert_array_equal(cube.data[10:20, 20:30], ibl.radiance[1][2])
    octa = ibl.atlas("octahedral")
    assert octa.projection == "octahedral" and octa.data.shape[1] == 18
    rgbm = ibl.atlas("rgbm")
    assert rgbm.data.dtype == np.uint8 and rgbm.data.shape[2] == 4
    q = unit_vectors(500)
    ref = sample_levels(ibl.radiance, q, 2.5)
    for levels, proj, rgbm_flag in ((ibl.octahedral, "octahedral", False), (ibl.radiance, "cube", True)):
        got = sample_levels(levels, q, 2.5, projection=proj, rgbm=rgbm_flag)
        assert np.abs(got - ref).mean() / ref.mean() < 0.02, proj


# ----------------------------------------------------------------------------- GLSL against numpy


def glsl_mappings(ctx, d: np.ndarray) -> np.ndarray:
    """Run mapping.glsl on directions d (N, 3): per direction (u, v, face, s, t, octa u, octa v, 0)."""
    mapping = (ROOT / "compare" / "ibl" / "mapping.glsl").read_text()
    vs = "#version 330 core\nvoid main() { vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));" \
         " gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }"
    fs = ("#version 330 core\n" + mapping + """
uniform sampler2D u_dirs;
layout(location = 0) out vec4 out_a;
layout(location = 1) out vec4 out_b;
void main() {
    vec3 d = texelFetch(u_dirs, ivec2(gl_FragCoord.xy), 0).xyz;
    vec2 st;
    int face = env_cube_face(d, st);
    out_a = vec4(env_direction_to_uv(d), float(face), st.x);
    out_b = vec4(st.y, env_octahedral_encode(d), 0.0);
}""")
    n = len(d)
    prog = ctx.program(vertex_shader=vs, fragment_shader=fs)
    tex = ctx.texture((n, 1), 3, np.ascontiguousarray(d, np.float32).tobytes(), dtype="f4")
    outs = [ctx.texture((n, 1), 4, dtype="f4") for _ in range(2)]
    fbo = ctx.framebuffer(outs)
    vao = ctx.vertex_array(prog, [])
    try:
        fbo.use()
        ctx.enable_only(ctx.NOTHING)
        tex.use(0)
        prog["u_dirs"].value = 0
        vao.render(vertices=3)
        ctx.finish()
        a = np.frombuffer(fbo.read(components=4, dtype="f4", attachment=0), np.float32).reshape(n, 4)
        b = np.frombuffer(fbo.read(components=4, dtype="f4", attachment=1), np.float32).reshape(n, 4)
    finally:
        for obj in (vao, fbo, *outs, tex, prog):
            obj.release()
    return np.concatenate([a, b], axis=1)


def test_glsl_mappings_equal_numpy(gl_ctx):
    from compare.image.encodings import octahedral_encode
    from compare.scene.equirect import direction_to_uv

    d = unit_vectors(4096, seed=7)
    d = np.concatenate([d, np.eye(3), -np.eye(3)])
    out = glsl_mappings(gl_ctx, d).astype(np.float64)
    uv = direction_to_uv(d)
    du = np.abs(out[:, 0] - uv[:, 0])
    pole = np.abs(d[:, 1]) > 1 - 1e-9  # u is undefined straight up and down
    assert np.minimum(du, 1 - du)[~pole].max() < 1e-5
    # GLSL's float acos is an approximation (llvmpipe: 5e-5, 0.05 texel of a 1024 x 512 map).
    assert np.abs(out[:, 1] - uv[:, 1]).max() < 1e-4
    face, s, t = face_coordinates(d)
    assert np.array_equal(out[:, 2].astype(int), face)
    np.testing.assert_allclose(out[:, 3], s, atol=1e-5)
    np.testing.assert_allclose(out[:, 4], t, atol=1e-5)
    np.testing.assert_allclose(out[:, 5:7], octahedral_encode(d), atol=1e-5)


# ----------------------------------------------------------------------------- the distributor


def env_scene(frames_hint: str = "constant", **env):
    return parse_scene({
        "camera": {"position": [0, 0, 4], "target": [0, 0, 0], "fov": 35, "resolution": [48, 48]},
        "materials": {"white": {"base_color": [1.0, 1.0, 1.0], "roughness": 1.0}},
        "meshes": [{"shape": "sphere", "radius": 1.0, "material": "white", "segments": 96, "rings": 48}],
        "environment": env or {"constant": [1.0, 1.0, 1.0]},
        "render": {"max_depth": 2},
    }, ROOT / "tests" / f"{frames_hint}.toml")


@pytest.mark.parametrize("frames, count", [(128, None), (16, 16), (16, 5), (9, 40), (2, None)])
def test_plan_env_samples_follow_the_paper(frames, count):
    from compare.progressive.schedule.distributor import plan
    from compare.progressive.schedule.distributor import round_half_up

    p = plan(env_scene(), frames, env_samples=count)
    n = frames if count is None else count
    samples = [(fp.frame, s) for fp in p for s in fp.env_samples]
    assert len(samples) == n
    n_d = round_half_up(n / 2)
    assert p.env_counts == (n_d, n - n_d)
    assert [s.kind for _, s in samples] == ["diffuse" if k % 2 == 0 else "specular" for k in range(n)]
    assert [f for f, _ in samples] == [1 + (k * (frames - 1)) // n for k in range(n)]
    assert not p[0].env_samples, "frame 0 is environment-only, no occlusion"
    assert p.env_frames == len({f for f, _ in samples})
    for kind, count_k in zip(("diffuse", "specular"), p.env_counts):
        weights = [s.weight for _, s in samples if s.kind == kind]
        assert sum(weights) == pytest.approx(frames)  # the paper's m / n: each kind's weights sum to m
        assert all(w == pytest.approx(frames / count_k) for w in weights)
    assert p.paper_env_weights == pytest.approx(tuple(frames / c for c in p.env_counts))
    pts = np.array([(*s.u, s.t) for _, s in samples])
    assert pts.min() >= 0 and pts.max() < 1


def test_plan_without_environment_or_occlusion_has_no_env_samples(tmp_path):
    from compare.progressive.schedule.distributor import plan

    cornell = __import__("compare.scene.loader", fromlist=["load_scene"]).load_scene(CORNELL)
    assert cornell.environment is None
    p = plan(cornell, 32)
    assert p.env_frames == 0 and p.env_counts == (0, 0) and not any(fp.env_samples for fp in p)
    assert plan(env_scene(), 32, env_samples=0).env_frames == 0
    assert plan(env_scene(), 1).env_frames == 0 and plan(env_scene(), 1).notes
    with pytest.raises(ValueError, match="env_samples"):
        plan(env_scene(), 8, env_samples=-1)


# ----------------------------------------------------------------------------- brute force


def test_groundtruth_in_a_constant_environment_is_the_albedo():
    from compare.ibl.groundtruth import reflected_radiance

    cos = np.array([1.0, 0.6, 0.2])
    n = np.tile([0.0, 0.0, 1.0], (3, 1))
    v = np.stack([np.sqrt(1 - cos ** 2), np.zeros(3), cos], -1)
    for rough, metallic in ((0.0, 0.0), (0.3, 1.0), (1.0, 0.0)):
        got, se = reflected_radiance(np.ones((8, 16, 3), np.float32), n, v, [0.8] * 3, metallic, rough, samples=1024)
        exact = directional_albedo(rough, cos, [0.8] * 3, metallic, 4096)
        assert np.all(np.abs(got - exact) < 4 * se + 1e-3), (rough, got, exact, se)


def test_groundtruth_finds_the_sun():
    """A Lambert normal under the sky with its 3.6e4 sun: E/π from an exact texel sum, within the MC noise."""
    from compare.ibl.groundtruth import reflected_radiance

    sky = procedural_map("sky", {"width": 256})
    n = np.array([[0.0, 1.0, 0.0], [0.6, 0.6, -0.53]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    got, se = reflected_radiance(sky, n, n, [1.0] * 3, 0.0, 1.0, samples=4096, materials="diffuse")
    exact = irradiance_at(source_chain(sky, 64)[0], n) / math.pi
    sun = sample_equirect(sky, np.array([0.0, 1.0, 0.0])).sum()
    assert sun < 2.0 and exact.min() > 0.5  # the sun's light, not the sky's, dominates the second normal
    assert np.all(np.abs(got - exact) < 4 * se + 0.01 * exact), (got, exact, se)
    assert np.all(se < 0.03 * got)

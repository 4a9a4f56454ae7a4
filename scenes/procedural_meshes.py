"""Deterministic procedural meshes: lofts, lathes, and the suite's kitchen and car stand-ins.

The paper evaluates an Italian kitchen and a Nissan Skyline, both third-party
downloads. The suite ships stand-ins built here for the same lighting
situations, written once as small GLB files by ``scenes/generate.py`` (the
scene files include them; nothing here runs when a scene is loaded):

* :func:`coupe_parts`: a sports coupé whose body is lofted from smooth
  superelliptic cross-sections (beltline, greenhouse with tumblehome, hood and
  trunk decks, wheel arches), glass cut out of the same surface along grid
  lines, tyres and rims turned on a lathe, a rear wing, mirrors and lights.
* :func:`kitchen_parts`: a counter run of lower cabinets with doors and
  drawers, bar handles, a stone countertop with a cooktop, upper cabinets, a
  plank floor, walls, and turned metal props (pan, pot, utensil crock, ladle).

Every function returns ``[(name, TriangleMesh, material name)]`` in metres,
+Y up, with outward normals. Only numpy; same inputs, same triangles.
"""

from __future__ import annotations

import math

import numpy as np

from compare.scene.geometry import (TriangleMesh, _mesh, box, cylinder, quad_from_corners, ray_cast, sphere, transform_matrix,
                       vertex_normals)

Part = tuple[str, TriangleMesh, str]


# ----------------------------------------------------------------------------- building blocks


def merge(meshes: list[TriangleMesh]) -> TriangleMesh:
    """One mesh from several (vertices concatenated, indices offset)."""
    ps, ns, uvs, idx, off = [], [], [], [], 0
    for m in meshes:
        ps.append(m.positions)
        ns.append(m.normals)
        uvs.append(m.uvs)
        idx.append(m.indices.astype(np.int64) + off)
        off += len(m.positions)
    return _mesh(np.concatenate(ps), np.concatenate(ns), np.concatenate(uvs), np.concatenate(idx))


def _signed_volume(p: np.ndarray, idx: np.ndarray) -> float:
    a, b, c = p[idx[:, 0]], p[idx[:, 1]], p[idx[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def grid_mesh(points: np.ndarray, *, wrap: bool = True, outward: bool | None = True,
              keep: np.ndarray | None = None) -> TriangleMesh:
    """Triangles over a (S, M, 3) grid of points, smooth area-weighted normals.

    ``wrap`` joins column M−1 to column 0 (a closed cross-section). ``outward``
    True flips the winding if needed so that the enclosed volume is positive
    (outward normals of a closed surface); None keeps the grid's own winding.
    ``keep`` (S−1, M or M−1) selects the quads to emit (normals are still
    computed over the whole grid, so cut-outs keep the smooth shading).
    """
    pts = np.asarray(points, dtype=np.float64)
    s, m = pts.shape[:2]
    cols = m if wrap else m - 1
    i, j = np.meshgrid(np.arange(s - 1), np.arange(cols), indexing="ij")
    a = i * m + j
    b = i * m + (j + 1) % m
    c = (i + 1) * m + (j + 1) % m
    d = (i + 1) * m + j
    quads = np.stack([a, b, c, d], -1)
    tris_all = np.concatenate([quads[..., [0, 1, 2]].reshape(-1, 3), quads[..., [0, 2, 3]].reshape(-1, 3)])
    flat = pts.reshape(-1, 3)
    if outward and _signed_volume(flat, tris_all) < 0:
        quads = quads[..., ::-1]
        tris_all = tris_all[:, ::-1]
    n = vertex_normals(flat, tris_all)
    if keep is not None:
        quads = quads[np.asarray(keep, dtype=bool)]
    quads = quads.reshape(-1, 4)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    used = np.unique(tris)
    remap = np.full(len(flat), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    uv = np.stack(np.meshgrid(np.linspace(0, 1, s), np.linspace(0, 1, m), indexing="ij"), -1).reshape(-1, 2)
    return _drop_degenerate(_mesh(flat[used], n[used], uv[used], remap[tris]))


def lathe(profile, segments: int = 64, *, sharp: tuple[int, ...] = ()) -> TriangleMesh:
    """Surface of revolution about +Y of a closed (radius, height) profile.

    The profile runs from the axis round to the axis (first and last radius 0
    make a closed solid) or is a closed loop away from the axis (a torus-like
    ring). ``sharp`` are profile indices where the surface creases: the profile
    is split there so each piece gets its own smooth normals.
    """
    prof = np.asarray(profile, dtype=np.float64)
    if prof[0, 0] > 0:  # a loop away from the axis: close it
        prof = np.vstack([prof, prof[:1]])
    cuts = sorted({0, len(prof) - 1, *sharp})
    pieces = [prof[a:b + 1] for a, b in zip(cuts[:-1], cuts[1:])]
    phi = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
    cos, sin = np.cos(phi), np.sin(phi)
    meshes = []
    for piece in pieces:
        r, y = piece[:, 0], piece[:, 1]
        pts = np.stack([r[:, None] * cos[None, :], np.repeat(y[:, None], segments, 1), -r[:, None] * sin[None, :]], -1)
        meshes.append(grid_mesh(pts, wrap=True, outward=None))
    mesh = merge(meshes)
    if _signed_volume(mesh.positions.astype(np.float64), mesh.indices.astype(np.int64)) < 0:
        mesh = _mesh(mesh.positions, -mesh.normals, mesh.uvs, mesh.indices[:, ::-1])
    return _drop_degenerate(mesh)


def _drop_degenerate(mesh: TriangleMesh) -> TriangleMesh:
    """Remove zero-area triangles (lathe poles) so the stand-ins carry none."""
    p = mesh.positions.astype(np.float64)
    i = mesh.indices.astype(np.int64)
    area = np.linalg.norm(np.cross(p[i[:, 1]] - p[i[:, 0]], p[i[:, 2]] - p[i[:, 0]]), axis=1)
    return _mesh(mesh.positions, mesh.normals, mesh.uvs, i[area > 1e-14])


def place(mesh: TriangleMesh, translate=(0.0, 0.0, 0.0), rotate=(0.0, 0.0, 0.0), scale=(1.0, 1.0, 1.0)) -> TriangleMesh:
    return mesh.transformed(transform_matrix(translate, rotate, scale))


def _smoothstep(e0: float, e1: float, x):
    t = np.clip((np.asarray(x, dtype=np.float64) - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3 - 2 * t)


def _spow(x, p):
    return np.sign(x) * np.abs(x) ** p


# ----------------------------------------------------------------------------- the coupé

#: Body dimensions (m): length, width, wheelbase, front/rear track, wheel radius, tyre width.
COUPE = {"length": 4.50, "width": 1.80, "wheelbase": 2.67, "track": 1.50, "wheel_radius": 0.33, "tyre_width": 0.245,
         "clearance": 0.17}


def _coupe_profile(x: np.ndarray) -> dict[str, np.ndarray]:
    """Per-station section parameters along the car (x forward, front at +length/2)."""
    half = COUPE["length"] / 2
    u = x / half
    plan = np.clip(1 - np.abs(u) ** 7, 0.0, 1.0) ** (1 / 7)                 # rounded ends in plan view
    side = np.clip(1 - np.abs(u) ** 10, 0.0, 1.0) ** (1 / 10)               # rounded ends in side view
    w = COUPE["width"] / 2 * plan * (0.94 + 0.06 * (1 - u**2))
    belt = np.interp(x, [-half, -1.6, 0.9, 1.5, half], [0.90, 0.92, 0.86, 0.80, 0.70])
    # Greenhouse height above the beltline: hood, windshield, roof, rear window, trunk deck.
    cabin = _smoothstep(1.02, 0.05, x) * _smoothstep(-1.62, -0.72, x)
    deck = np.interp(x, [-half, -1.7, 1.1, half], [0.05, 0.09, 0.09, 0.04])
    top = deck + (1.335 - belt - deck) * cabin
    roof_w = w * (0.92 - 0.24 * cabin)
    bottom = COUPE["clearance"] + 0.16 * _smoothstep(1.55, half, np.abs(x)) ** 1.5
    # Wheel arches: the bottom rises over each wheel, full width (the body is a single loft).
    for xw in (COUPE["wheelbase"] / 2, -COUPE["wheelbase"] / 2):
        ra = COUPE["wheel_radius"] + 0.06
        d = np.clip(1 - ((x - xw) / ra) ** 2, 0.0, None)
        bottom = np.maximum(bottom, np.where(d > 0, COUPE["wheel_radius"] + np.sqrt(d) * ra, 0.0))
    bottom = np.minimum(bottom, belt - 0.05)
    mid = belt
    return {"w": w, "roof_w": roof_w, "belt": belt, "top": top * side, "low": (mid - bottom) * side,
            "mid": mid, "cabin": cabin}


def coupe_body(stations: int = 120, around: int = 80) -> tuple[TriangleMesh, TriangleMesh]:
    """The lofted body: (paint, glass), cut from one smooth surface along grid lines."""
    half = COUPE["length"] / 2
    # Stations denser at the rounded ends; the first and last sections collapse to a point (closed ends).
    x = half * np.sin(np.linspace(-1.0, 1.0, stations) * math.pi / 2)
    pr = _coupe_profile(x)
    t = np.linspace(0.0, 2 * math.pi, around, endpoint=False) + math.pi / around
    c, sn = np.cos(t), np.sin(t)
    upper = sn > 0
    # Cross-section: lower half a boxy superellipse, upper half tapering to the roof width.
    lift = np.abs(sn) ** 0.9
    zw = np.where(upper[None, :], pr["w"][:, None] + (pr["roof_w"] - pr["w"])[:, None] * lift[None, :],
                  pr["w"][:, None])
    z = _spow(c, 2 / 5.0)[None, :] * zw
    yu = pr["mid"][:, None] + np.abs(sn[None, :]) ** (2 / 2.6) * pr["top"][:, None]
    yl = pr["mid"][:, None] - np.abs(sn[None, :]) ** (2 / 7.0) * pr["low"][:, None]
    y = np.where(upper[None, :], yu, yl)
    pts = np.stack([np.repeat(x[:, None], around, 1), y, z], -1)
    # Glass: side windows, windshield and rear window, in (station, angle) space.
    xs = 0.5 * (x[1:] + x[:-1])
    tc = t + math.pi / around
    cab = _coupe_profile(xs)["cabin"]
    band = (np.sin(tc) > 0)[None, :]
    yq = 0.25 * (y[1:, :] + y[:-1, :] + np.roll(y[1:, :], -1, 1) + np.roll(y[:-1, :], -1, 1))
    zq = 0.25 * (z[1:, :] + z[:-1, :] + np.roll(z[1:, :], -1, 1) + np.roll(z[:-1, :], -1, 1))
    belt = _coupe_profile(xs)["belt"][:, None]
    roof = (belt + _coupe_profile(xs)["top"][:, None])
    side = band & (cab[:, None] > 0.97) & (yq > belt + 0.07) & (yq < roof - 0.07) & (xs[:, None] > -0.95) \
        & (xs[:, None] < 0.25)
    # B-pillar gap between the door glass and the quarter window.
    side &= ~((xs[:, None] > -0.42) & (xs[:, None] < -0.34))
    wsh = band & (xs[:, None] > 0.12) & (xs[:, None] < 0.92) & (yq > belt + 0.05) \
        & (np.abs(zq) < _coupe_profile(xs)["roof_w"][:, None] * 0.93 - 0.02)
    rear = band & (xs[:, None] < -0.80) & (xs[:, None] > -1.52) & (yq > belt + 0.08) \
        & (np.abs(zq) < _coupe_profile(xs)["roof_w"][:, None] * 0.90 - 0.03)
    glass = side | wsh | rear
    return grid_mesh(pts, keep=~glass), grid_mesh(pts, keep=glass)


def tyre(radius: float, width: float, rim: float, segments: int = 56) -> TriangleMesh:
    """A tyre about the +Y axis: rounded tread and sidewalls, open towards the rim."""
    h = width / 2
    k = 10
    a = np.linspace(-math.pi / 2, math.pi / 2, 2 * k + 1)
    shoulder = 0.035
    tread = [(radius - shoulder + shoulder * math.cos(v), math.sin(v) * h) for v in a]
    n = len(tread)
    ring = [(rim, -h * 0.92), *tread, (rim, h * 0.92), (rim - 0.005, h * 0.8), (rim - 0.005, -h * 0.8)]
    return lathe(ring, segments, sharp=(1, n, n + 1, n + 2, n + 3))


def rim(radius: float, width: float, spokes: int = 6, segments: int = 56) -> TriangleMesh:
    """A wheel rim about +Y (its outer face at +Y): barrel, dished face, hub and spokes."""
    h = width / 2
    barrel = lathe([(0.0, -h * 0.7), (radius, -h * 0.7), (radius, h * 0.85), (radius - 0.015, h * 0.9),
                    (radius * 0.9, h * 0.55), (0.0, h * 0.55)], segments, sharp=(1, 2, 3, 4))
    hub = place(cylinder(radius * 0.22, 0.06, 32), translate=(0, h * 0.6, 0))
    spoke_parts = []
    for k in range(spokes):
        ang = math.radians(360.0 * k / spokes)
        r0 = radius * 0.55
        spoke_parts.append(place(box((radius * 0.78, 0.04, 0.06)),
                                 translate=(r0 * math.cos(ang), h * 0.62, -r0 * math.sin(ang)),
                                 rotate=(0, math.degrees(ang), 0)))
    return merge([barrel, hub, *spoke_parts])


def _down_hit(mesh: TriangleMesh, x: float, z: float) -> tuple[np.ndarray, np.ndarray]:
    """The highest point of ``mesh`` above (x, z) and the unit face normal there, facing up (a vertical
    ray cast down, :func:`compare.scene.geometry.ray_cast`)."""
    tris = mesh.positions.astype(np.float64)[mesh.indices]
    o, d = np.array([x, 1e3, z]), np.array([0.0, -1.0, 0.0])
    t, k = ray_cast(o[None], d[None], tris)
    if k[0] < 0:
        raise ValueError(f"no surface of the mesh above ({x}, {z})")
    e1, e2 = tris[k[0], 1] - tris[k[0], 0], tris[k[0], 2] - tris[k[0], 0]
    n = np.cross(e1, e2)
    n /= np.linalg.norm(n)
    return o + t[0] * d, n if n[1] > 0 else -n


def hood_badge(body: TriangleMesh, x: float = 1.72, size: float = 0.16, lift: float = 0.004) -> TriangleMesh:
    """A square ``size`` quad (UVs 0…1, the image's top towards the nose) on the body's centre line at
    ``x``, ``lift`` above it along the body's normal there: the card of an alpha-masked round badge."""
    c, normal = _down_hit(body, x, 0.0)
    forward = np.array([1.0, 0.0, 0.0]) - normal * normal[0]
    forward /= np.linalg.norm(forward)
    side = np.cross(forward, normal)  # forward × up: +z, the car's right seen from above
    c = c + normal * lift
    h = size / 2
    # counter-clockwise seen from above (the quad faces ``normal``), v = 0 at the nose (the badge is symmetric)
    return quad_from_corners(np.array([c + forward * h + side * h, c + forward * h - side * h,
                                       c - forward * h - side * h, c - forward * h + side * h]))


def coupe_parts() -> list[Part]:
    """The coupé, front towards +X, wheels on y = 0, centred on the origin."""
    paint, glass = coupe_body()
    parts: list[Part] = [("body", paint, "paint"), ("glass", glass, "glass")]
    r, tw = COUPE["wheel_radius"], COUPE["tyre_width"]
    rim_r = r * 0.62
    for fx, name in ((1, "front"), (-1, "rear")):
        for side in (1, -1):
            c = (fx * COUPE["wheelbase"] / 2, r, side * COUPE["track"] / 2)
            label = f"{name} {'right' if side > 0 else 'left'}"
            # Wheel axis along Z; rotating +Y to ±Z puts the rim's face outwards.
            rot = (90.0 if side > 0 else -90.0, 0.0, 0.0)
            parts.append((f"tyre {label}", place(tyre(r, tw, rim_r), translate=c, rotate=rot), "rubber"))
            parts.append((f"rim {label}", place(rim(rim_r, tw), translate=c, rotate=rot), "rim"))
    half = COUPE["length"] / 2
    pr = _coupe_profile(np.array([-half + 0.12, -half + 0.25, 0.55]))
    deck_y = float(pr["mid"][1] + pr["top"][1])
    # Rear wing on two posts.
    wing = merge([place(box((0.26, 0.025, 1.52)), translate=(-half + 0.16, deck_y + 0.16, 0), rotate=(0, 0, -6)),
                  place(box((0.10, 0.16, 0.04)), translate=(-half + 0.2, deck_y + 0.07, 0.55)),
                  place(box((0.10, 0.16, 0.04)), translate=(-half + 0.2, deck_y + 0.07, -0.55))])
    parts.append(("rear wing", wing, "paint"))
    # Mirrors at the base of the A-pillars.
    belt = float(_coupe_profile(np.array([0.7]))["belt"][0])
    w = float(_coupe_profile(np.array([0.7]))["w"][0])
    mirrors = merge([place(sphere(1.0, 24, 12), translate=(0.70, belt + 0.09, s * (w + 0.04)),
                           scale=(0.07, 0.05, 0.09)) for s in (1, -1)])
    parts.append(("mirrors", mirrors, "paint"))
    # Head lights, four round tail lights, grille, exhaust.
    front = _coupe_profile(np.array([half - 0.10]))
    fy = float(front["mid"][0]) - 0.02
    heads = merge([place(sphere(1.0, 24, 12), translate=(half - 0.06, fy, s * 0.50), scale=(0.075, 0.04, 0.14))
                   for s in (1, -1)])
    parts.append(("headlights", heads, "headlight"))
    rear = _coupe_profile(np.array([-half + 0.06]))
    ry = float(rear["mid"][0]) - 0.04
    tails = merge([place(cylinder(0.065, 0.06, 32), translate=(-half + 0.055, ry, s * zc), rotate=(0, 0, 90))
                   for s in (1, -1) for zc in (0.42, 0.66)])
    parts.append(("taillights", tails, "taillight"))
    grille = place(sphere(1.0, 32, 12), translate=(half - 0.035, float(front["mid"][0]) - 0.17, 0),
                   scale=(0.04, 0.06, 0.36))
    parts.append(("grille", grille, "trim"))
    parts.append(("badge", hood_badge(paint), "badge"))
    exhaust = merge([place(cylinder(0.045, 0.16, 24), translate=(-half + 0.08, 0.27, s * 0.5), rotate=(0, 0, 90))
                     for s in (1,)])
    parts.append(("exhaust", exhaust, "rim"))
    return parts


# ----------------------------------------------------------------------------- the kitchen

#: Room (m): x across the counter run, z from the back wall (z = 0) towards the camera.
KITCHEN = {"width": 4.2, "depth": 3.8, "height": 2.7, "counter_height": 0.9, "counter_depth": 0.62,
           "upper_bottom": 1.45, "upper_top": 2.2, "upper_depth": 0.35}


def _panel(parts, name, size, centre, material):
    parts.append((name, place(box(size), translate=centre), material))


def pan(radius: float = 0.13, depth: float = 0.05, wall: float = 0.004) -> TriangleMesh:
    """A frying pan (flared walls, thick base) with a tubular handle along +X."""
    r0 = radius * 0.8
    prof = [(0.0, 0.0), (r0, 0.0), (r0 + 0.01, 0.004), (radius, depth), (radius - wall, depth),
            (r0 + 0.01 - wall, 0.004 + wall), (r0 - wall, wall * 1.5), (0.0, wall * 1.5)]
    body = lathe(prof, 64, sharp=(1, 3, 4, 6))
    handle = place(cylinder(0.011, 0.22, 24), translate=(radius + 0.10, depth * 0.85, 0), rotate=(0, 0, 80))
    return merge([body, handle])


def pot(radius: float = 0.11, height: float = 0.14, wall: float = 0.004) -> TriangleMesh:
    """A cooking pot with a lid and a knob."""
    prof = [(0.0, 0.0), (radius - 0.01, 0.0), (radius, 0.01), (radius, height), (radius - wall, height),
            (radius - wall, wall * 2), (0.0, wall * 2)]
    body = lathe(prof, 64, sharp=(1, 3, 4, 5))
    lid = lathe([(0.0, height + 0.03), (radius * 0.3, height + 0.028), (radius + 0.005, height + 0.004),
                 (radius + 0.005, height), (0.0, height + 0.005)], 64, sharp=(2, 3))
    knob = place(sphere(0.018, 16, 8), translate=(0, height + 0.04, 0))
    handles = [place(box((0.05, 0.012, 0.025)), translate=(s * (radius + 0.022), height * 0.8, 0)) for s in (1, -1)]
    return merge([body, lid, knob, *handles])


def crock(radius: float = 0.06, height: float = 0.16, wall: float = 0.006) -> TriangleMesh:
    prof = [(0.0, 0.0), (radius, 0.0), (radius, height), (radius - wall, height), (radius - wall, wall),
            (0.0, wall)]
    return lathe(prof, 48, sharp=(1, 2, 3, 4))


def ladle(length: float = 0.32, bowl: float = 0.04) -> TriangleMesh:
    """A ladle standing up: bowl at the bottom, straight handle along +Y."""
    k = 12
    a = np.linspace(0.0, math.pi / 2, k)
    outer = [(bowl * math.sin(v), bowl - bowl * math.cos(v)) for v in a]
    inner = [(max(bowl - 0.003, 0.0) * math.sin(v), bowl - (bowl - 0.003) * math.cos(v) + 0.003)
             for v in a[::-1]]
    cup = lathe(outer + inner, 32, sharp=(k - 1, k))
    handle = place(cylinder(0.006, length, 16), translate=(bowl * 0.9, bowl + length / 2, 0), rotate=(0, 0, 4))
    return merge([cup, handle])


def spatula(length: float = 0.30) -> TriangleMesh:
    blade = place(box((0.07, 0.09, 0.004)), translate=(0, 0.045, 0))
    handle = place(cylinder(0.007, length - 0.09, 16), translate=(0, 0.09 + (length - 0.09) / 2, 0))
    return merge([blade, handle])


def kitchen_parts() -> list[Part]:
    """The kitchen: room shell, counter run, upper cabinets and props, back wall at z = 0."""
    K = KITCHEN
    W, D, H = K["width"], K["depth"], K["height"]
    parts: list[Part] = []
    x0, x1 = -W / 2, W / 2
    # Room shell: floor planks, walls, ceiling (inward-facing quads made from thin boxes).
    plank_w, n_planks = 0.19, int(math.ceil(D / 0.19))
    for k in range(n_planks):
        z = k * plank_w + plank_w / 2
        width = min(plank_w, D - k * plank_w) - 0.003
        _panel(parts, f"floor plank {k}", (W, 0.02, width), (0.0, -0.01, z), "wood" if k % 3 else "wood_dark")
    _panel(parts, "back wall", (W, H, 0.05), (0.0, H / 2, -0.025), "wall")
    _panel(parts, "left wall", (0.05, H, D), (x0 - 0.025, H / 2, D / 2), "wall")
    _panel(parts, "right wall", (0.05, H, D), (x1 + 0.025, H / 2, D / 2), "wall")
    _panel(parts, "front wall", (W, H, 0.05), (0.0, H / 2, D + 0.025), "wall")
    _panel(parts, "ceiling", (W, 0.05, D), (0.0, H + 0.025, D / 2), "ceiling")
    # Lower cabinets along the back wall: plinth, carcass, fronts with a 3 mm gap.
    ch, cd = K["counter_height"], K["counter_depth"]
    plinth, top_t = 0.10, 0.04
    body_h = ch - top_t - plinth
    run0, run1 = x0 + 0.05, x1 - 0.05
    _panel(parts, "plinth", (run1 - run0, plinth, cd - 0.08), ((run0 + run1) / 2, plinth / 2, (cd - 0.08) / 2),
           "plinth")
    _panel(parts, "lower carcass", (run1 - run0, body_h, cd - 0.04), ((run0 + run1) / 2, plinth + body_h / 2,
                                                                       (cd - 0.04) / 2), "cabinet")
    units = [("drawers", 0.6), ("door", 0.6), ("drawers", 0.8), ("door2", 0.9), ("drawers", 0.6)]
    total = sum(w for _, w in units)
    scale = (run1 - run0) / total
    x = run0
    front_z = cd - 0.04 + 0.01
    gap = 0.003
    handles: list[TriangleMesh] = []
    for k, (kind, w) in enumerate(units):
        w *= scale
        cx = x + w / 2
        if kind == "drawers":
            heights = [0.16, 0.25, 0.35]
            hsum = sum(heights)
            y = plinth + body_h
            for j, hh in enumerate(heights):
                hh = hh / hsum * body_h
                _panel(parts, f"drawer {k}.{j}", (w - 2 * gap, hh - 2 * gap, 0.02), (cx, y - hh / 2, front_z),
                       "cabinet")
                handles.append(place(cylinder(0.006, w * 0.45, 16), translate=(cx, y - 0.05, front_z + 0.035),
                                     rotate=(0, 0, 90)))
                handles.extend(place(box((0.012, 0.012, 0.025)), translate=(cx + s * w * 0.2, y - 0.05,
                                                                             front_z + 0.022)) for s in (1, -1))
                y -= hh
        else:
            leaves = 2 if kind == "door2" else 1
            lw = w / leaves
            for j in range(leaves):
                lx = x + lw * (j + 0.5)
                _panel(parts, f"door {k}.{j}", (lw - 2 * gap, body_h - 2 * gap, 0.02),
                       (lx, plinth + body_h / 2, front_z), "cabinet")
                # Handles on the opening edge: the right edge of a single door and of a pair's left leaf.
                hx = lx + (lw * 0.38 if j == 0 else -lw * 0.38)
                handles.append(place(cylinder(0.006, 0.16, 16), translate=(hx, plinth + body_h - 0.14,
                                                                           front_z + 0.035)))
                handles.extend(place(box((0.012, 0.025, 0.012)), translate=(hx, plinth + body_h - 0.14 + s * 0.06,
                                                                           front_z + 0.022)) for s in (1, -1))
        x += w
    parts.append(("handles", merge(handles), "steel_brushed"))
    # Countertop (glossy stone) with a small overhang, a black glass cooktop.
    _panel(parts, "countertop", (run1 - run0 + 0.02, top_t, cd + 0.03),
           ((run0 + run1) / 2, ch - top_t / 2, (cd + 0.03) / 2), "stone")
    cook_x = run0 + (0.6 + 0.6 + 0.4) * scale
    _panel(parts, "cooktop", (0.58, 0.006, 0.5), (cook_x, ch + 0.003, 0.30), "ceramic")
    # Backsplash and upper cabinets with doors and short handles.
    ub, ut, ud = K["upper_bottom"], K["upper_top"], K["upper_depth"]
    _panel(parts, "backsplash", (run1 - run0, ub - ch, 0.012), ((run0 + run1) / 2, (ch + ub) / 2, 0.006),
           "tile")
    _panel(parts, "upper carcass", (run1 - run0, ut - ub, ud - 0.02), ((run0 + run1) / 2, (ub + ut) / 2,
                                                                       (ud - 0.02) / 2), "cabinet")
    n_upper = 6
    uw = (run1 - run0) / n_upper
    uhandles = []
    for k in range(n_upper):
        cx = run0 + uw * (k + 0.5)
        _panel(parts, f"upper door {k}", (uw - 2 * gap, ut - ub - 2 * gap, 0.02), (cx, (ub + ut) / 2, ud),
               "cabinet")
        hx = cx + (uw * 0.38 if k % 2 == 0 else -uw * 0.38)
        uhandles.append(place(cylinder(0.006, 0.12, 16), translate=(hx, ub + 0.12, ud + 0.025)))
    parts.append(("upper handles", merge(uhandles), "steel_brushed"))
    # Props on the counter: pan on the cooktop, pot, utensil crock with utensils, cutting board.
    top = ch
    parts.append(("pan", place(pan(), translate=(cook_x - 0.13, top + 0.006, 0.38), rotate=(0, -25, 0)),
                  "steel_brushed"))
    parts.append(("pot", place(pot(), translate=(cook_x + 0.16, top + 0.006, 0.20)), "steel_polished"))
    crock_x = run0 + 0.35
    parts.append(("crock", place(crock(), translate=(crock_x, top, 0.18)), "ceramic_white"))
    utensils = merge([place(ladle(), translate=(crock_x - 0.02, top + 0.01, 0.17), rotate=(0, 30, 8)),
                      place(spatula(), translate=(crock_x + 0.02, top + 0.01, 0.19), rotate=(-6, 70, -6)),
                      place(ladle(0.28, 0.03), translate=(crock_x, top + 0.01, 0.16), rotate=(8, 200, -4))])
    parts.append(("utensils", utensils, "steel_polished"))
    board_x = run0 + (0.6 + 0.6 + 0.8 + 0.45) * scale
    _panel(parts, "cutting board", (0.42, 0.022, 0.28), (board_x, top + 0.011, 0.36), "wood_board")
    # Two bar stools in front of the counter: their shadows overlap on the floor.
    for k, sx in enumerate((-0.55, 0.35)):
        sz = cd + 0.95
        seat = place(cylinder(0.19, 0.04, 40), translate=(sx, 0.70, sz))
        legs = [place(cylinder(0.015, 0.68, 12), translate=(sx + 0.13 * math.cos(a), 0.34, sz + 0.13 * math.sin(a)))
                for a in np.linspace(0, 2 * math.pi, 4, endpoint=False) + math.pi / 4]
        ring = place(cylinder(0.16, 0.015, 40), translate=(sx, 0.25, sz))
        parts.append((f"stool {k}", merge([seat, *legs, ring]), "stool"))
    return parts

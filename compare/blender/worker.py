"""Render one job with bpy: run as ``python worker.py JOB_FOLDER SPAWN_TIME`` by :mod:`compare.blender.render`.

This file runs in its own process under a Python that has ``bpy`` (Blender as
a module keeps global state and may crash; a process per render keeps both
away from the caller). It imports only the standard library, numpy and bpy,
never :mod:`compare`, so it works under any such interpreter. It reads
``job.json`` and ``meshes.npz`` written by :func:`compare.blender.export.build_job`,
builds the scene, renders, and writes ``render.exr`` (linear scene-referred
RGB, Blender's own EXR writer) and ``result.json`` (timings and what was used).
Every decision about the mapping lives in ``export.py``; this file only
copies numbers into Blender.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
import traceback


def _matrix(rows):
    from mathutils import Matrix

    return Matrix([list(r) for r in rows])


#: The colour attribute of glTF's COLOR_0 on the meshes Blender gets.
VERTEX_COLORS = "COLOR_0"


def _principled(bpy, name: str, mat: dict):
    """A material with one Principled BSDF set from the glTF parameters (see export.py)."""
    m = bpy.data.materials.new(name)
    if getattr(m, "node_tree", None) is None:
        m.use_nodes = True
    nodes, links = m.node_tree.nodes, m.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.distribution = mat["distribution"]
    inp = bsdf.inputs
    inp["Base Color"].default_value = (*mat["base_color"], 1.0)
    inp["Metallic"].default_value = mat["metallic"]
    inp["Roughness"].default_value = mat["roughness"]
    inp["IOR"].default_value = 1.5
    inp["Specular IOR Level"].default_value = mat["specular_ior_level"]
    inp["Specular Tint"].default_value = (1.0, 1.0, 1.0, 1.0)
    inp["Diffuse Roughness"].default_value = 0.0
    for key in ("Coat Weight", "Sheen Weight", "Subsurface Weight", "Transmission Weight", "Anisotropic",
                "Thin Film Thickness"):
        inp[key].default_value = 0.0
    base_tex = None
    if mat.get("base_color_texture"):
        tex = base_tex = _image_node(bpy, nodes, links, mat, "base_color_texture", mat["base_color_texture"],
                                     mat["base_color_texture_colorspace"])
        links.new(tex.outputs["Color"], inp["Base Color"])
    if mat.get("vertex_colors"):  # glTF's COLOR_0 multiplies the base colour (white on meshes without it)
        vc = nodes.new("ShaderNodeVertexColor")
        vc.layer_name = VERTEX_COLORS
        product = nodes.new("ShaderNodeMix")
        product.data_type = "RGBA"
        product.blend_type = "MULTIPLY"
        product.inputs["Factor"].default_value = 1.0
        if base_tex is not None:
            links.new(base_tex.outputs["Color"], product.inputs["A"])
        else:
            product.inputs["A"].default_value = (*mat["base_color"], 1.0)
        links.new(vc.outputs["Color"], product.inputs["B"])
        links.new(product.outputs["Result"], inp["Base Color"])
    for key, value in mat.get("principled_inputs", {}).items():
        inp[key].default_value = tuple(value) if isinstance(value, list) else value
    for m_in in mat.get("input_maps", []):
        # a glTF extension's map (linear; a colour map sRGB) times its factor, on the input it drives
        colour = m_in["channel"] == "Color"
        tex = _image_node(bpy, nodes, links, mat, m_in["map"], m_in["file"], "sRGB" if colour else "Non-Color")
        if colour:
            product = nodes.new("ShaderNodeMix")
            product.data_type = "RGBA"
            product.blend_type = "MULTIPLY"
            product.inputs["Factor"].default_value = 1.0
            links.new(tex.outputs["Color"], product.inputs["A"])
            product.inputs["B"].default_value = (*m_in["factor"], 1.0)
            links.new(product.outputs["Result"], inp[m_in["input"]])
            continue
        if m_in["channel"] == "Alpha":
            value = tex.outputs["Alpha"]
        else:
            split = nodes.new("ShaderNodeSeparateColor")
            links.new(tex.outputs["Color"], split.inputs["Color"])
            value = split.outputs[m_in["channel"]]
        scaled = nodes.new("ShaderNodeMath")
        scaled.operation = "MULTIPLY"
        links.new(value, scaled.inputs[0])
        scaled.inputs[1].default_value = float(m_in["factor"])
        links.new(scaled.outputs["Value"], inp[m_in["input"]])
    if mat.get("alpha_mask"):
        _alpha_mask(m, nodes, links, inp["Alpha"], mat["alpha_mask"], base_tex)
    if mat.get("alpha_blend") is not None:
        _alpha_blend(nodes, links, inp["Alpha"], mat["alpha_blend"], base_tex)
    if mat.get("volume_absorption"):
        absorb = nodes.new("ShaderNodeVolumeAbsorption")
        absorb.inputs["Color"].default_value = (*mat["volume_absorption"]["color"], 1.0)
        absorb.inputs["Density"].default_value = mat["volume_absorption"]["density"]
        links.new(absorb.outputs["Volume"], out.inputs["Volume"])
    if mat.get("metallic_roughness_texture"):
        # glTF's channels, as Blender's own glTF importer wires them: G = roughness, B = metallic.
        tex = _image_node(bpy, nodes, links, mat, "metallic_roughness_texture", mat["metallic_roughness_texture"],
                          "Non-Color")
        split = nodes.new("ShaderNodeSeparateColor")
        links.new(tex.outputs["Color"], split.inputs["Color"])
        links.new(split.outputs["Green"], inp["Roughness"])
        links.new(split.outputs["Blue"], inp["Metallic"])
    # glTF's tangent-space normal maps (+Y up the image, Blender's OpenGL convention) on the UV map's
    # tangents, their scale the node's strength: the surface's, and the coat's own (clearcoatNormalTexture)
    for key, name, scale, target in (("normal_texture", "normal_texture", "normal_scale", "Normal"),
                                     ("coat_normal_texture", "clearcoat_normal_texture", "coat_normal_scale",
                                      "Coat Normal")):
        if mat.get(key):
            tex = _image_node(bpy, nodes, links, mat, name, mat[key], "Non-Color")
            nmap = nodes.new("ShaderNodeNormalMap")
            nmap.space = "TANGENT"
            nmap.uv_map = mat["maps"][name]["uv_map"]  # glTF: the tangents of the normal map's own set
            nmap.inputs["Strength"].default_value = float(mat[scale])
            links.new(tex.outputs["Color"], nmap.inputs["Color"])
            links.new(nmap.outputs["Normal"], inp[target])
    if mat.get("anisotropy"):
        _anisotropy(bpy, nodes, links, mat, inp)
    if max(mat["emission"]) > 0:
        emitted = None
        if mat.get("emissive_texture"):
            # glTF's emissiveTexture (sRGB) times the emission factor
            tex = _image_node(bpy, nodes, links, mat, "emissive_texture", mat["emissive_texture"],
                              mat["emissive_texture_colorspace"])
            product = nodes.new("ShaderNodeMix")
            product.data_type = "RGBA"
            product.blend_type = "MULTIPLY"
            product.inputs["Factor"].default_value = 1.0
            links.new(tex.outputs["Color"], product.inputs["A"])
            product.inputs["B"].default_value = (*mat["emission"], 1.0)
            emitted = product.outputs["Result"]
        _one_sided_emission(nodes, links, inp["Emission Color"], mat["emission"], emitted)
        inp["Emission Strength"].default_value = 1.0
        if hasattr(m, "cycles") and hasattr(m.cycles, "emission_sampling"):
            m.cycles.emission_sampling = "FRONT"
    glass = _dispersive(nodes, links, mat, inp) if mat.get("dispersion") else None
    surface = bsdf.outputs["BSDF"] if not mat.get("thin_film") else _thin_film(bpy, nodes, links, mat, bsdf)
    if glass is not None:
        weight, shader = glass
        mix = nodes.new("ShaderNodeMixShader")
        if isinstance(weight, float):
            mix.inputs["Fac"].default_value = weight
        else:
            links.new(weight, mix.inputs["Fac"])
        links.new(surface, mix.inputs[1])
        links.new(shader, mix.inputs[2])
        surface = mix.outputs["Shader"]
    if mat.get("single_sided"):
        # glTF's doubleSided false: nothing behind the geometric normal, for every ray (as the reference
        # culls), by a transparent BSDF on back faces; EEVEE's own culling besides
        geo, clear, mix = (nodes.new("ShaderNodeNewGeometry"), nodes.new("ShaderNodeBsdfTransparent"),
                           nodes.new("ShaderNodeMixShader"))
        links.new(geo.outputs["Backfacing"], mix.inputs["Fac"])
        links.new(surface, mix.inputs[1])
        links.new(clear.outputs["BSDF"], mix.inputs[2])
        surface = mix.outputs["Shader"]
        if hasattr(m, "use_backface_culling"):
            m.use_backface_culling = True
    links.new(surface, out.inputs["Surface"])
    return m


def _alpha_blend(nodes, links, socket, alpha: float, base_tex) -> None:
    """glTF's BLEND coverage on the Principled BSDF's Alpha: alpha × the base-colour map's alpha."""
    socket.default_value = float(alpha)
    if base_tex is not None:
        base_tex.image.alpha_mode = "CHANNEL_PACKED"
        scaled = nodes.new("ShaderNodeMath")
        scaled.operation = "MULTIPLY"
        links.new(base_tex.outputs["Alpha"], scaled.inputs[0])
        scaled.inputs[1].default_value = float(alpha)
        links.new(scaled.outputs["Value"], socket)


def _alpha_mask(m, nodes, links, socket, mask: dict, base_tex) -> None:
    """glTF's alpha mask on the Principled BSDF's Alpha: 1 where alpha × the base-colour map's alpha is
    at least the cutoff, 0 (a hole, for camera rays, light and shadows in both engines) elsewhere."""
    alpha, cutoff = float(mask["alpha"]), float(mask["cutoff"])
    if base_tex is None:
        socket.default_value = 1.0 if alpha >= cutoff else 0.0
    else:
        # Colour and alpha as stored: no premultiplication of the colour by a mask's alpha.
        base_tex.image.alpha_mode = "CHANNEL_PACKED"
        scaled = nodes.new("ShaderNodeMath")
        scaled.operation = "MULTIPLY"
        links.new(base_tex.outputs["Alpha"], scaled.inputs[0])
        scaled.inputs[1].default_value = alpha
        test = nodes.new("ShaderNodeMath")
        test.operation = "GREATER_THAN"  # a > b: b just below the cutoff gives glTF's a >= cutoff
        links.new(scaled.outputs["Value"], test.inputs[0])
        test.inputs[1].default_value = cutoff - 1e-6
        links.new(test.outputs["Value"], socket)
    if hasattr(m, "use_transparent_shadow"):
        m.use_transparent_shadow = True  # EEVEE: shadows see the holes


def _math(nodes, links, operation: str, *args):
    """The output of a Math node of ``operation`` on ``args`` (numbers or sockets)."""
    node = nodes.new("ShaderNodeMath")
    node.operation = operation
    for i, arg in enumerate(args):
        if isinstance(arg, (int, float)):
            node.inputs[i].default_value = float(arg)
        else:
            links.new(arg, node.inputs[i])
    return node.outputs["Value"]


def _channels(bpy, nodes, links, mat: dict, name: str, path: str):
    """The R, G, B outputs of a linear map ``name`` of the material."""
    tex = _image_node(bpy, nodes, links, mat, name, path, "Non-Color")
    split = nodes.new("ShaderNodeSeparateColor")
    links.new(tex.outputs["Color"], split.inputs["Color"])
    return split.outputs["Red"], split.outputs["Green"], split.outputs["Blue"]


def _anisotropy(bpy, nodes, links, mat: dict, inp) -> None:
    """glTF's anisotropy on the Principled BSDF (export.anisotropy_inputs): Roughness (α_t α_b)^¼, Anisotropic
    (1 − α_b/α_t)/0.9, the rotation in turns, and the UV map's tangent, per point."""
    a = mat["anisotropy"]
    m = lambda op, *args: _math(nodes, links, op, *args)  # noqa: E731
    rough = inp["Roughness"]
    r = rough.links[0].from_socket if rough.is_linked else float(rough.default_value)
    strength, angle = a["strength"], a["rotation"]
    if a["map"]:
        red, green, blue = _channels(bpy, nodes, links, mat, "anisotropy_strength", a["map"])
        # the direction's angle in the tangent frame (a zero direction: atan2 gives 0, the tangent's)
        angle = m("ADD", m("ARCTAN2", m("MULTIPLY_ADD", green, 2.0, -1.0), m("MULTIPLY_ADD", red, 2.0, -1.0)),
                  a["rotation"])
        strength = m("MULTIPLY", blue, a["strength"])
    alpha = m("MULTIPLY", r, r)
    stretched = m("MULTIPLY_ADD", m("MULTIPLY", strength, strength), m("SUBTRACT", 1.0, alpha), alpha)
    links.new(m("SQRT", m("SQRT", m("MULTIPLY", stretched, alpha))), rough)
    ratio = m("DIVIDE", m("ADD", alpha, 1e-7), m("ADD", stretched, 1e-7))
    aniso = nodes.new("ShaderNodeMath")
    aniso.operation, aniso.use_clamp = "DIVIDE", True  # Blender's most: A = 1, α_b/α_t = 0.1
    links.new(m("SUBTRACT", 1.0, ratio), aniso.inputs[0])
    aniso.inputs[1].default_value = 0.9
    links.new(aniso.outputs["Value"], inp["Anisotropic"])
    if isinstance(angle, float):
        inp["Anisotropic Rotation"].default_value = angle / (2.0 * math.pi)
    else:
        links.new(m("DIVIDE", angle, 2.0 * math.pi), inp["Anisotropic Rotation"])
    tangent = nodes.new("ShaderNodeTangent")
    tangent.direction_type, tangent.uv_map = "UV_MAP", a["uv_map"]
    links.new(tangent.outputs["Tangent"], inp["Tangent"])


def _source(socket):
    """What drives an input: the socket linked to it, or its value."""
    if socket.is_linked:
        return socket.links[0].from_socket
    value = socket.default_value
    return float(value) if isinstance(value, float) else tuple(value)


def _dispersive(nodes, links, mat: dict, inp):
    """glTF's dispersion (export.dispersion_inputs): the Principled BSDF's transmission taken out and returned
    as (its weight, three Glass BSDFs of the channels' IORs added), each glass of the BSDF's roughness and
    normal, tinted by its channel times √(base colour) (Cycles' tint per interface of its Principled glass)."""
    weight = _source(inp["Transmission Weight"])
    for link in list(inp["Transmission Weight"].links):
        links.remove(link)
    inp["Transmission Weight"].default_value = 0.0
    base, rough, normal = _source(inp["Base Color"]), _source(inp["Roughness"]), inp["Normal"]
    root = nodes.new("ShaderNodeGamma")  # c^0.5
    root.inputs["Gamma"].default_value = 0.5
    if isinstance(base, tuple):
        root.inputs["Color"].default_value = base
    else:
        links.new(base, root.inputs["Color"])
    total = None
    for channel, ior in zip(((1.0, 0.0, 0.0, 1.0), (0.0, 1.0, 0.0, 1.0), (0.0, 0.0, 1.0, 1.0)),
                            mat["dispersion"]["iors"]):
        glass = nodes.new("ShaderNodeBsdfGlass")
        glass.distribution = "GGX"
        glass.inputs["IOR"].default_value = ior
        if isinstance(rough, float):
            glass.inputs["Roughness"].default_value = rough
        else:
            links.new(rough, glass.inputs["Roughness"])
        if normal.is_linked:
            links.new(normal.links[0].from_socket, glass.inputs["Normal"])
        tint = nodes.new("ShaderNodeMix")
        tint.data_type, tint.blend_type = "RGBA", "MULTIPLY"
        tint.inputs["Factor"].default_value = 1.0
        links.new(root.outputs["Color"], tint.inputs["A"])
        tint.inputs["B"].default_value = channel
        links.new(tint.outputs["Result"], glass.inputs["Color"])
        if total is None:
            total = glass.outputs["BSDF"]
            continue
        add = nodes.new("ShaderNodeAddShader")
        links.new(total, add.inputs[0])
        links.new(glass.outputs["BSDF"], add.inputs[1])
        total = add.outputs["Shader"]
    return weight, total


def _thin_film(bpy, nodes, links, mat: dict, bsdf):
    """glTF's iridescence (export.thin_film_inputs): the Principled BSDF's Thin Film, mixed by the factor with
    the BSDF without it (a copy: its inputs, values and links); returns the surface's shader output."""
    f = mat["thin_film"]
    film = bsdf
    if f["factor"] != 1.0 or f["factor_map"]:
        film = nodes.new("ShaderNodeBsdfPrincipled")
        film.distribution = bsdf.distribution
        for src, dst in zip(bsdf.inputs, film.inputs):
            if hasattr(src, "default_value"):
                dst.default_value = src.default_value
            for link in src.links:
                links.new(link.from_socket, dst)
    film.inputs["Thin Film IOR"].default_value = f["ior"]
    thickness = film.inputs["Thin Film Thickness"]
    thickness.default_value = f["thickness_max"]
    if f["thickness_map"]:
        _, green, _ = _channels(bpy, nodes, links, mat, "iridescence_thickness_max", f["thickness_map"])
        links.new(_math(nodes, links, "MULTIPLY_ADD", green, f["thickness_max"] - f["thickness_min"],
                        f["thickness_min"]), thickness)
    if film is bsdf:
        return bsdf.outputs["BSDF"]
    mix = nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = f["factor"]
    if f["factor_map"]:
        red, _, _ = _channels(bpy, nodes, links, mat, "iridescence", f["factor_map"])
        links.new(_math(nodes, links, "MULTIPLY", red, f["factor"]), mix.inputs["Fac"])
    links.new(bsdf.outputs["BSDF"], mix.inputs[1])
    links.new(film.outputs["BSDF"], mix.inputs[2])
    return mix.outputs["Shader"]


def _image_node(bpy, nodes, links, mat: dict, name: str, path: str, colorspace: str):
    """An image texture node of ``path`` read as the material's map ``name`` is (export.blender_map_reading):
    on its UV layer, through its texture transform (a Mapping node), with its wrap and filter; a wrap per axis
    by math nodes (repeat: WRAP, mirror: PINGPONG, clamp: a clamped ADD) ahead of a clamped lookup."""
    reading = mat["maps"][name]
    tex = nodes.new("ShaderNodeTexImage")
    img = bpy.data.images.load(path, check_existing=True)
    img.colorspace_settings.name = colorspace
    tex.image = img
    tex.interpolation = reading["interpolation"]
    tex.extension = reading["extension"]
    uv = nodes.new("ShaderNodeUVMap")
    uv.uv_map = reading["uv_map"]
    vector = uv.outputs["UV"]
    mapping = reading["uv_mapping"]
    if mapping:
        node = nodes.new("ShaderNodeMapping")
        node.vector_type = "POINT"
        node.inputs["Location"].default_value = mapping["location"]
        node.inputs["Rotation"].default_value = mapping["rotation"]
        node.inputs["Scale"].default_value = mapping["scale"]
        links.new(vector, node.inputs["Vector"])
        vector = node.outputs["Vector"]
    if reading["axis_wraps"]:
        split, join = nodes.new("ShaderNodeSeparateXYZ"), nodes.new("ShaderNodeCombineXYZ")
        links.new(vector, split.inputs["Vector"])
        for axis, wrap in zip("XY", reading["axis_wraps"]):
            op = nodes.new("ShaderNodeMath")
            op.operation = {"repeat": "WRAP", "mirror": "PINGPONG", "clamp": "ADD"}[wrap]
            links.new(split.outputs[axis], op.inputs[0])
            op.inputs[1].default_value = 1.0 if wrap != "clamp" else 0.0
            op.inputs[2].default_value = 0.0
            op.use_clamp = wrap == "clamp"
            links.new(op.outputs["Value"], join.inputs[axis])
        vector = join.outputs["Vector"]
    links.new(vector, tex.inputs["Vector"])
    return tex


def _one_sided_emission(nodes, links, socket, color, source=None) -> None:
    """Drive ``socket`` with ``color`` (or the output ``source``) on front faces and black on back faces
    (Mitsuba's area emitter)."""
    geo = nodes.new("ShaderNodeNewGeometry")
    mix = nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.inputs["A"].default_value = (*color, 1.0)
    if source is not None:
        links.new(source, mix.inputs["A"])
    mix.inputs["B"].default_value = (0.0, 0.0, 0.0, 1.0)
    links.new(geo.outputs["Backfacing"], mix.inputs["Factor"])
    links.new(mix.outputs["Result"], socket)


def _emission_material(bpy, name: str, color, strength: float = 1.0):
    """Black diffuse on the back, ``color`` emitted from the front (EEVEE's visible stand-in for a light)."""
    m = bpy.data.materials.new(name)
    if getattr(m, "node_tree", None) is None:
        m.use_nodes = True
    nodes, links = m.node_tree.nodes, m.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    em = nodes.new("ShaderNodeEmission")
    em.inputs["Strength"].default_value = strength
    _one_sided_emission(nodes, links, em.inputs["Color"], color)
    links.new(em.outputs["Emission"], out.inputs["Surface"])
    return m


def _black_material(bpy, name: str):
    m = bpy.data.materials.new(name)
    if getattr(m, "node_tree", None) is None:
        m.use_nodes = True
    nodes = m.node_tree.nodes
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    d = nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    m.node_tree.links.new(d.outputs["BSDF"], out.inputs["Surface"])
    return m


def _mesh(bpy, np, name: str, positions, normals, uvs, indices, uvs1=None, colors=None):
    """A mesh object from world-space triangles with per-vertex normals and UVs (``uvs1``: a second layer,
    glTF's TEXCOORD_1; ``colors``: glTF's COLOR_0, linear RGBA per vertex)."""
    me = bpy.data.meshes.new(name)
    nv, nt = len(positions), len(indices)
    me.vertices.add(nv)
    me.vertices.foreach_set("co", np.ascontiguousarray(positions, dtype=np.float32).ravel())
    me.loops.add(3 * nt)
    me.loops.foreach_set("vertex_index", np.ascontiguousarray(indices, dtype=np.int32).ravel())
    me.polygons.add(nt)
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * nt, 3, dtype=np.int32))
    # No me.validate(): it would drop degenerate triangles (a UV sphere's poles) and put the
    # per-loop arrays below out of step; Blender renders such triangles as nothing anyway.
    me.update(calc_edges=True)
    uv_layer = me.uv_layers.new(name="UVMap")
    uv_layer.data.foreach_set("uv", np.ascontiguousarray(uvs[indices.ravel()], dtype=np.float32).ravel())
    if uvs1 is not None:
        second = me.uv_layers.new(name="UVMap.001")
        second.data.foreach_set("uv", np.ascontiguousarray(uvs1[indices.ravel()], dtype=np.float32).ravel())
    if colors is not None:
        attribute = me.color_attributes.new(name=VERTEX_COLORS, type="FLOAT_COLOR", domain="POINT")
        attribute.data.foreach_set("color", np.ascontiguousarray(colors, dtype=np.float32).ravel())
    me.shade_smooth()
    me.normals_split_custom_set_from_vertices(np.asarray(normals, dtype=np.float32))
    obj = bpy.data.objects.new(name, me)
    return obj


def _quad(bpy, np, name: str, corners, normal):
    """A one-triangle-pair quad from four corners, wound so that its front faces ``normal``."""
    p = np.asarray(corners, dtype=np.float32)
    idx = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int32)
    if np.dot(np.cross(p[1] - p[0], p[2] - p[0]), normal) < 0:
        idx = idx[:, ::-1].copy()
    n = np.tile(np.asarray(normal, dtype=np.float32), (4, 1))
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32)
    return _mesh(bpy, np, name, p, n, uv, idx)


def _world(bpy, env, folder: str):
    world = bpy.data.worlds.new("World")
    if getattr(world, "node_tree", None) is None:
        world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputWorld")
    bg = nodes.new("ShaderNodeBackground")
    links.new(bg.outputs["Background"], out.inputs["Surface"])
    if env is None:
        bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        bg.inputs["Strength"].default_value = 0.0
    elif "constant" in env:
        bg.inputs["Color"].default_value = (*env["constant"], 1.0)
        bg.inputs["Strength"].default_value = 1.0
    else:
        tex = nodes.new("ShaderNodeTexEnvironment")
        tex.image = bpy.data.images.load(os.path.join(folder, env["file"]))
        tex.image.colorspace_settings.name = "Linear Rec.709"
        tex.interpolation = "Linear"
        tex.projection = "EQUIRECTANGULAR"
        coord = nodes.new("ShaderNodeTexCoord")
        combine = nodes.new("ShaderNodeCombineXYZ")
        # lookup = M · d, one dot product per row: no Euler-angle conventions involved.
        for k, row in enumerate(env["lookup"]):
            dot = nodes.new("ShaderNodeVectorMath")
            dot.operation = "DOT_PRODUCT"
            dot.inputs[1].default_value = tuple(row)
            links.new(coord.outputs["Generated"], dot.inputs[0])
            links.new(dot.outputs["Value"], combine.inputs[k])
        links.new(combine.outputs["Vector"], tex.inputs["Vector"])
        links.new(tex.outputs["Color"], bg.inputs["Color"])
        bg.inputs["Strength"].default_value = env["strength"]
    return world


def _gl_driver() -> str:
    """Which OpenGL/Vulkan driver this process loaded (EEVEE), read from its memory map."""
    try:
        with open("/proc/self/maps") as f:
            libs = {line.split()[-1].rsplit("/", 1)[-1] for line in f if ".so" in line}
    except OSError:
        return "unknown"
    if any(lib.startswith("libnvidia-glcore") or lib.startswith("libnvidia-eglcore") for lib in libs):
        return "NVIDIA"
    names = []
    if "libEGL_mesa.so.0.0.0" in libs or any(lib.startswith("libEGL_mesa") for lib in libs):
        names.append("Mesa EGL")
    if "swrast_dri.so" in libs or any("gallium" in lib for lib in libs):
        names.append("llvmpipe (software)")
    return ", ".join(names) or "unknown"


#: Blender's glTF importer turns glTF's +Y up into Blender's +Z up: (x, y, z) → (x, −z, y). Its inverse maps
#: what it imported back into the suite's frame (which is glTF's).
_FROM_IMPORTED = ((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0), (0.0, -1.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))


def _import_gltf(bpy, sc, entry: dict) -> None:
    """Import ``entry["file"]`` with Blender's glTF importer into ``sc``, without its cameras and lights, under
    an empty that undoes the importer's axis change and applies ``entry["matrix"]`` (the include's)."""
    import addon_utils
    from mathutils import Matrix

    addon_utils.enable("io_scene_gltf2", default_set=True)
    before = set(bpy.data.objects)
    bpy.ops.import_scene.gltf(filepath=entry["file"])
    new = [o for o in bpy.data.objects if o not in before]
    for o in [o for o in new if o.type in ("CAMERA", "LIGHT")]:
        new.remove(o)
        bpy.data.objects.remove(o, do_unlink=True)
    root = bpy.data.objects.new("import", None)
    sc.collection.objects.link(root)
    root.matrix_world = Matrix(entry["matrix"]) @ Matrix(_FROM_IMPORTED)
    for o in new:
        if o.parent is None:
            o.parent = root
    for o in new:  # the importer links to the active collection: make sure they are in the scene
        if o.name not in sc.collection.all_objects:
            sc.collection.objects.link(o)


def build(bpy, np, job: dict, folder: str):
    """Build the Blender scene of ``job``; returns the bpy scene."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    engine = job["engine"]
    sc.render.engine = engine
    w, h = job["resolution"]
    sc.render.resolution_x, sc.render.resolution_y = int(w), int(h)
    sc.render.resolution_percentage = 100
    sc.render.pixel_aspect_x = sc.render.pixel_aspect_y = 1.0
    sc.render.film_transparent = False
    sc.render.use_compositing = False
    sc.render.use_sequencer = False
    sc.render.dither_intensity = 0.0
    sc.render.use_motion_blur = False
    if job["threads"] > 0:
        sc.render.threads_mode = "FIXED"
        sc.render.threads = int(job["threads"])
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0

    cam_data = bpy.data.cameras.new("camera")
    cam_data.type = "PERSP"
    cam_data.sensor_fit = "VERTICAL"
    cam_data.sensor_height = job["camera"]["sensor_height"]
    cam_data.lens = job["camera"]["lens"]
    cam_data.shift_x = cam_data.shift_y = 0.0
    cam_data.clip_start = job["camera"]["clip_start"]
    cam_data.clip_end = job["camera"]["clip_end"]
    cam = bpy.data.objects.new("camera", cam_data)
    cam.matrix_world = _matrix(job["camera"]["matrix"])
    sc.collection.objects.link(cam)
    sc.camera = cam

    mats = {name: _principled(bpy, name, m) for name, m in job["materials"].items()}
    arrays = np.load(os.path.join(folder, "meshes.npz"))
    for mesh in job["meshes"]:
        k = mesh["key"]
        obj = _mesh(bpy, np, mesh["name"], arrays[f"{k}_positions"], arrays[f"{k}_normals"], arrays[f"{k}_uvs"],
                    arrays[f"{k}_indices"], arrays[f"{k}_uvs1"] if f"{k}_uvs1" in arrays.files else None,
                    arrays[f"{k}_colors"] if f"{k}_colors" in arrays.files else None)
        obj.data.materials.append(mats[mesh["material"]])
        sc.collection.objects.link(obj)
    for entry in job.get("imports", []):
        _import_gltf(bpy, sc, entry)

    black = _black_material(bpy, "light backing")
    for k, light in enumerate(job["lights"]):
        data = bpy.data.lights.new(light["name"], "AREA")
        data.shape = "RECTANGLE"
        data.size, data.size_y = light["size"]
        data.color = light["color"]
        data.energy = light["energy"]
        data.spread = 3.141592653589793  # 180°: Lambertian; smaller spreads renormalise the lobe
        data.normalize = True
        data.use_shadow = True
        if engine == "BLENDER_EEVEE":
            data.use_shadow_jitter = True  # soft shadows: the shadow origin moves over the light per sample
            data.use_custom_distance = True
            data.cutoff_distance = light["cutoff_distance"]
        obj = bpy.data.objects.new(light["name"], data)
        obj.matrix_world = _matrix(light["matrix"])
        obj.visible_camera = True
        sc.collection.objects.link(obj)
        # The backing quad: black and occluding like Mitsuba's rectangle; for EEVEE it also
        # shows the light's radiance to the camera, since EEVEE never draws lights.
        n = np.asarray(light["normal"], dtype=np.float64)
        corners = np.asarray(light["corners"], dtype=np.float64) - n * light["backing_offset"]
        quad = _quad(bpy, np, f"{light['name']} backing", corners, n)
        if engine == "BLENDER_EEVEE":
            quad.data.materials.append(_emission_material(bpy, f"{light['name']} emission", light["radiance"]))
            quad.visible_shadow = False
            quad.hide_probe_volume = quad.hide_probe_sphere = quad.hide_probe_plane = True
        else:
            quad.data.materials.append(black)
        sc.collection.objects.link(quad)

    for light in job.get("punctual", []):
        kind = {"point": "POINT", "spot": "SPOT", "directional": "SUN"}[light["kind"]]
        data = bpy.data.lights.new(light["name"], kind)
        data.color = light["color"]
        data.energy = light["energy"]
        data.use_shadow = True
        if kind == "SUN":
            data.angle = 0.0
        else:
            data.shadow_soft_size = 0.0  # a point: glTF's lights have no size
        if engine == "BLENDER_EEVEE" and kind != "SUN":
            data.use_custom_distance = True
            data.cutoff_distance = light["cutoff_distance"]
        if kind == "SPOT":
            data.spot_size = light["spot_size"]
            data.spot_blend = light["spot_blend"]
            data.show_cone = False
        obj = bpy.data.objects.new(light["name"], data)
        obj.matrix_world = _matrix(light["matrix"])
        sc.collection.objects.link(obj)

    sc.world = _world(bpy, job["environment"], folder)
    # A hidden background: a transparent film, whose premultiplied RGB (what is written) holds no world
    # where camera rays (through transparent surfaces too) hit nothing; the world still lights the scene,
    # glass still refracts it (film_transparent_glass stays off).
    env = job["environment"]
    sc.render.film_transparent = env is not None and env.get("background", True) is False

    settings = job["settings"]
    if engine == "CYCLES":
        try:
            prefs = bpy.context.preferences.addons["cycles"].preferences
            prefs.compute_device_type = "NONE"
        except (KeyError, AttributeError, TypeError):
            pass
        target = sc.cycles
        if sc.world is not None:
            sc.world.cycles.sampling_method = "AUTOMATIC"
    else:
        target = sc.eevee
        sc.render.filter_size = job["eevee_filter_size"]
    for key, value in settings.items():
        if not hasattr(target, key):
            raise ValueError(f"settings: {engine} has no setting {key!r}")
        setattr(target, key, value)
    return sc


def _die_with_parent(parent: int) -> None:
    """On Linux, end with the process that started this one (PR_SET_PDEATHSIG): a ``compare`` that is killed,
    or that unwinds from SIGTERM while this process is still starting (before it holds this process's
    handle), never leaves a render running. ``parent``: its pid, to catch a parent gone before the call."""
    import ctypes
    import signal

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(1, int(signal.SIGKILL), 0, 0, 0) != 0:  # 1: PR_SET_PDEATHSIG
            return
    except (OSError, AttributeError):  # not Linux: the caller's own clean-up is all there is
        return
    if parent and os.getppid() != parent:
        os._exit(1)


def main(folder: str, spawn_time: float) -> int:
    _die_with_parent(int(os.environ.get("COMPARE_PARENT_PID", "0") or 0))
    t_start = time.time()
    result: dict = {"interpreter_seconds": max(0.0, t_start - spawn_time)}
    t0 = time.perf_counter()
    import numpy as np

    import bpy

    result["import_seconds"] = time.perf_counter() - t0
    with open(os.path.join(folder, "job.json")) as f:
        job = json.load(f)
    t0 = time.perf_counter()
    sc = build(bpy, np, job, folder)
    result["build_seconds"] = time.perf_counter() - t0
    # What the Principled BSDFs were set to, read back from Blender (the run's metadata records it).
    result["distributions"] = {
        name: node.distribution for name in job["materials"]
        for node in getattr(bpy.data.materials.get(name), "node_tree", None).nodes
        if node.type == "BSDF_PRINCIPLED"}

    key = "samples" if job["engine"] == "CYCLES" else "taa_render_samples"
    target = sc.cycles if job["engine"] == "CYCLES" else sc.eevee
    full = getattr(target, key)
    s = sc.render.image_settings
    s.file_format = "OPEN_EXR"
    s.color_mode = "RGB"
    s.color_depth = "32"
    s.exr_codec = "ZIP"

    if job["warmup"]:
        # One sample first: compiles shaders and allocates buffers outside the timed render.
        setattr(target, key, 1)
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=False)
        result["warmup_seconds"] = time.perf_counter() - t0

    # Checkpoints: renders of fewer samples with the same seed. Cycles' and EEVEE's
    # sample sequences are deterministic, so a render of n samples is the first n
    # samples of the full one, i.e. what a progressive render shows after n samples.
    result["ladder"] = []
    for n in job.get("ladder") or []:
        setattr(target, key, int(n))
        t0, c0 = time.perf_counter(), time.process_time()
        bpy.ops.render.render(write_still=False)
        seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
        name = f"checkpoint-{int(n)}.exr"
        bpy.data.images["Render Result"].save_render(os.path.join(folder, name), scene=sc)
        result["ladder"].append({"samples": int(n), "seconds": seconds, "cpu_seconds": cpu, "file": name})

    setattr(target, key, full)
    # Wall time is what a user waits; CPU time (all threads of this process, llvmpipe's
    # included) is what it costs, and does not grow when other processes share the cores.
    t0, c0 = time.perf_counter(), time.process_time()
    bpy.ops.render.render(write_still=False)
    result["render_seconds"] = time.perf_counter() - t0
    result["render_cpu_seconds"] = time.process_time() - c0

    t0 = time.perf_counter()
    bpy.data.images["Render Result"].save_render(os.path.join(folder, job["output"]), scene=sc)
    result["write_seconds"] = time.perf_counter() - t0

    result.update({
        "blender_version": bpy.app.version_string,
        "blender_build_hash": bpy.app.build_hash.decode() if isinstance(bpy.app.build_hash, bytes)
        else str(bpy.app.build_hash),
        "engine": job["engine"],
        "threads": sc.render.threads,
        "gl_driver": _gl_driver() if job["engine"] == "BLENDER_EEVEE" else "",
        "working_space": _working_space(bpy),
    })
    with open(os.path.join(folder, job["result"]), "w") as f:
        json.dump(result, f, indent=1)
    return 0


def _working_space(bpy) -> str:
    try:
        return str(bpy.data.colorspace.working_space)
    except AttributeError:
        return "Linear Rec.709"


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1], float(sys.argv[2])))
    except Exception:  # noqa: BLE001 - report everything to the caller through stderr and the exit status
        traceback.print_exc()
        sys.exit(3)

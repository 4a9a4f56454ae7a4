// The G-buffer's targets as a full-screen pass reads them (texel for texel), each at its unit
// of GBUFFER in compare/progressive/gl/units.py (GBuffer.bind in gbuffer.py binds them).
// The frame's G-buffer (gbuffer.glsl) and the irradiance volume's bake (probes_gbuffer.glsl,
// one cube face per tile) write the same four, with their own w:
//
//   target       frame                                   bake
//   u_position   world position, w = kind (0 background, world position, w = distance to the probe
//                1 surface, 2 light quad)
//   u_normal     shading normal, w = roughness           unit normal, w = kind
//   u_material   base colour, a = metallic               diffuse albedo, w = side (1 front, -1 back)
//   u_emission   emitted radiance towards the camera,    emitted radiance towards the probe
//                a = the occlusion map's factor
//
// A pass that reads fewer of them leaves the others unused (the linker drops them).

uniform sampler2D u_position;
uniform sampler2D u_normal;
uniform sampler2D u_material;
uniform sampler2D u_emission;

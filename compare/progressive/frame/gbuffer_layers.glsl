// The G-buffer's material layers (gbuffer.glsl's targets 4 to 6 with LAYERS): load_layers(p) sets
// layers.glsl's g_layers at pixel p. Included after layers.glsl; a no-op without LAYERS.

#if LAYERS
uniform sampler2D u_layer_f0;     // dielectric F0, a = specular weight
uniform sampler2D u_layer_coat;   // clearcoat, clearcoat roughness
uniform sampler2D u_layer_sheen;  // sheen colour, a = sheen roughness

void load_layers(ivec2 p) {
    vec4 f = texelFetch(u_layer_f0, p, 0);
    vec4 c = texelFetch(u_layer_coat, p, 0);
    vec4 s = texelFetch(u_layer_sheen, p, 0);
    g_layers = MaterialLayers(f.rgb, f.a, c.x, c.y, s.rgb, s.a);
}
#else
void load_layers(ivec2 p) {}
#endif

"""OpenGL plumbing: the context, the shader loader, the texture-unit table, the passes' protocol, read-backs,
mipmaps, the sRGB probe, the full-screen triangle."""

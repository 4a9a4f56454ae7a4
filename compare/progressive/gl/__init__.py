"""OpenGL plumbing: the context, the shader loader, read-backs, mipmaps, the sRGB probe, the full-screen triangle."""

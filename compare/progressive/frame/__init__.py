"""What every frame draws: the scene on the GPU, its materials, the G-buffer, the depth floor, accumulation and composition."""

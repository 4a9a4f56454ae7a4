"""Indirect diffuse light: irradiance probes and their shading."""

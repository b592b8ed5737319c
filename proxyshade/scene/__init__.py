"""Proxy modelling tools (Bonneel et al. 2010, §3): a terrain pushed and pulled by Gaussian
strokes, spheres instanced along paths, keyframed cameras; written as USD scenes."""

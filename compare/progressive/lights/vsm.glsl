// Variance shadow maps: visibility from the filtered moments (mu, m2) = (E[z], E[z^2]) of
// the occluder distance z around the lookup (Donnelly & Lauritzen 2006; Lauritzen, GPU
// Gems 3, ch. 8). Included by direct.glsl; mirrored in numpy by
// compare.progressive.lights.shadow.chebyshev_visibility (tests/test_vsm.py checks one against
// the other). See shadow.py for the maths and the choice of the constants.

// Chebyshev's one-tailed bound P(z >= d) <= p_max = s2 / (s2 + (d - mu)^2) for d > mu,
// with the variance s2 = m2 - mu^2 kept at least min_variance (float32 cancellation,
// and acne on surfaces seen nearly edge-on); a receiver not behind the mean is lit.
float vsm_upper_bound(vec2 moments, float d, float min_variance) {
    float mu = moments.x;
    if (d <= mu) {
        return 1.0;
    }
    float variance = max(moments.y - mu * mu, min_variance);
    float t = d - mu;
    return variance / (variance + t * t);
}

// Light-bleeding reduction: p_max below `amount` becomes 0, the rest is rescaled to
// [0, 1] (linstep(amount, 1, p_max)).
float vsm_reduce_bleeding(float p_max, float amount) {
    return clamp((p_max - amount) / (1.0 - amount), 0.0, 1.0);
}

// The visibility of a receiver at distance d: bound, then bleeding reduction.
float vsm_visibility(vec2 moments, float d, float min_variance, float bleeding) {
    return vsm_reduce_bleeding(vsm_upper_bound(moments, d, min_variance), bleeding);
}

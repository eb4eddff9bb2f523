// ---- btfgmm: the Gaussian mixture, the paper's Eq. (8)-(11) (src/render/glsl/mixture.glsl)
// Each component m is four texels from BTF_COMPONENTS + 4 m:
//   (mu_x, mu_y, mu_alpha_i, mu_beta_i), (mu_alpha_v, mu_beta_v, c_x, c_y),
//   (c_alpha_i, c_beta_i, c_alpha_v, c_beta_v), (mu_r, mu_g, mu_b, base)
// in model units, with c_n = -1 / (2 sigma_mn^2) and base = log w_m - 1/2 sum_n log sigma_mn^2
// over the six inputs (Eq. 9-10's normalisations; 2 pi cancels), mu_x, mu_y in [0, W), [0, H).

// Eq. (8): sum_m W_m(x_I) mu_m,colour with Eq. (9)'s weights from the exponents
// t_m = base_m + sum_n c_mn (x_n - mu_mn)^2 (Eq. 10; x and y in the minimum image: the
// Gaussians wrap around the tile), in the log domain: the sums are kept relative to the
// largest t so far (rescaled when a larger one comes), so nothing overflows.
vec3 btf_mixture_expectation(vec2 xy, vec4 angles) {
  float top = -3.0e38;
  float weight = 0.0;
  vec3 colour = vec3(0.0);
  ivec2 at = btf_at(BTF_COMPONENTS);
  for (int m = 0; m < BTF_M; ++m, at = btf_next(at, 4)) {
    vec4 a = btf_fetch(at, 0), b = btf_fetch(at, 1), c = btf_fetch(at, 2), d = btf_fetch(at, 3);
    vec2 dxy = xy - a.xy;
    dxy -= BTF_TILE * floor(dxy * (1.0 / BTF_TILE) + 0.5);
    vec4 dang = angles - vec4(a.zw, b.xy);
    float t = d.w + dot(dxy * dxy, b.zw) + dot(dang * dang, c);
    if (t > top) {
      float s = exp(top - t);
      weight *= s;
      colour *= s;
      top = t;
    }
    float e = exp(t - top);
    weight += e;
    colour += e * d.rgb;
  }
  return colour / weight;
}

// The BTF at tile position uv (in tiles: 1.0 = one tile; the tile repeats) for unit light
// and view directions in the local frame, in the data's units (0-255 levels for 8-bit data,
// linear values for HDR): Eq. (11), the expectation in data units plus the mean BRDF.
vec3 btf(vec2 uv, vec3 light, vec3 view) {
  vec2 xy = btf_tile_position(uv);
  vec4 angles = vec4(btf_onion_slice(light), btf_onion_slice(view)) / BTF_ANGLE_UNIT;
  return btf_mixture_expectation(xy, angles) * BTF_COLOUR_UNIT + btf_mean_brdf(light, view);
}

// ---- btfgmm: PLM RF, Filip & Haindl 2004 (src/render/glsl/plm_rf.glsl) ------------------
// Per texel, measured view and channel a Lafortune lobe in the light w (a unit vector),
// Y = rho max(0, Cx wx + Cy wy + Cz wz)^n, then per image a polynomial
// sum_j a_j (Y / BTF_PLM_SCALE)^j whose coefficients, known at the measured lights, are
// blended with the light's barycentric weights; views and positions interpolated as
// measured_images.glsl says. Tables: lobe parameter p (rho, Cx, Cy, Cz, n) of view v as an
// image from BTF_PLM_LOBES + (5 v + p) W H; coefficient a_j of view v and light i (r, g, b, -)
// at BTF_PLM_POLYNOMIALS + (v (BTF_PLM_DEGREE + 1) + j) ni + i.

vec3 btf(vec2 uv, vec3 light, vec3 view) {
  BtfBilinear at = btf_bilinear(uv);
  BtfWeights wl = btf_light_weights(light), wv = btf_view_weights(view);
  vec3 w = light / length(light);
  int image = int(BTF_TILE.x * BTF_TILE.y);
  vec3 rgb = vec3(0.0);
  for (int j = 0; j < 3; ++j) {
    if (wv.weight[j] == 0.0) continue;
    int v = wv.index[j];
    vec3 a[BTF_PLM_DEGREE + 1];
    for (int d = 0; d <= BTF_PLM_DEGREE; ++d) {
      a[d] = vec3(0.0);
      int row = BTF_PLM_POLYNOMIALS + (v * (BTF_PLM_DEGREE + 1) + d) * BTF_LIGHTS;
      for (int i = 0; i < 3; ++i)
        if (wl.weight[i] != 0.0) a[d] += wl.weight[i] * btf_texel(row + wl.index[i]).rgb;
    }
    vec3 value = vec3(0.0);
    for (int c = 0; c < 4; ++c) {
      int lobe = BTF_PLM_LOBES + 5 * v * image + at.pixel[c];
      vec3 rho = btf_texel(lobe).rgb, cx = btf_texel(lobe + image).rgb,
           cy = btf_texel(lobe + 2 * image).rgb, cz = btf_texel(lobe + 3 * image).rgb,
           n = btf_texel(lobe + 4 * image).rgb;
      vec3 base = cx * w.x + cy * w.y + cz * w.z;
      vec3 y = vec3(greaterThan(base, vec3(0.0))) * rho * pow(max(base, vec3(1e-30)), n);
      y *= 1.0 / BTF_PLM_SCALE;
      vec3 p = a[BTF_PLM_DEGREE];
      for (int d = BTF_PLM_DEGREE - 1; d >= 0; --d) p = p * y + a[d];
      value += at.weight[c] * p;
    }
    rgb += wv.weight[j] * value;
  }
  return rgb;
}

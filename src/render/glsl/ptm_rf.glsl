// ---- btfgmm: PTM RF, Malzbender et al. 2001 (src/render/glsl/ptm_rf.glsl) ---------------
// A polynomial texture map per measured view, analytic in the light: per texel and channel
// a0 lu^2 + a1 lv^2 + a2 lu lv + a3 lu + a4 lv + a5, (lu, lv) the unit light's x and y;
// views interpolated as measured_images.glsl says. Table: the coefficient a_k of view v as an
// image from BTF_PTM + (6 v + k) W H.

vec3 btf(vec2 uv, vec3 light, vec3 view) {
  BtfBilinear at = btf_bilinear(uv);
  BtfWeights wv = btf_view_weights(view);
  vec3 l = light / length(light);
  float terms[6] = float[6](l.x * l.x, l.y * l.y, l.x * l.y, l.x, l.y, 1.0);
  int image = int(BTF_TILE.x * BTF_TILE.y);
  vec3 rgb = vec3(0.0);
  for (int j = 0; j < 3; ++j) {
    if (wv.weight[j] == 0.0) continue;
    vec3 value = vec3(0.0);
    for (int k = 0; k < 6; ++k)
      value += terms[k] * btf_image_at(BTF_PTM + (6 * wv.index[j] + k) * image, at);
    rgb += wv.weight[j] * value;
  }
  return rgb;
}

// ---- btfgmm: PCA RF, Sattler et al. 2003 (src/render/glsl/pca_rf.glsl) ------------------
// A PCA per view: the image of (light, view) is mean_view + sum_k w_k(view, light)
// eigen-image_k(view), interpolated as measured_images.glsl says. Tables: view v's mean image
// from BTF_PCA_MEAN + v W H; its eigen-image k from BTF_PCA_EIGEN + (v 4 BTF_PCA_GROUPS + k) W H;
// the weights of view v and light l from BTF_PCA_WEIGHTS + (v ni + l) BTF_PCA_GROUPS, four
// components a texel.

vec3 btf(vec2 uv, vec3 light, vec3 view) {
  BtfBilinear at = btf_bilinear(uv);
  BtfWeights wl = btf_light_weights(light), wv = btf_view_weights(view);
  int image = int(BTF_TILE.x * BTF_TILE.y);
  vec3 rgb = vec3(0.0);
  for (int j = 0; j < 3; ++j) {
    if (wv.weight[j] == 0.0) continue;
    int v = wv.index[j];
    vec3 value = btf_image_at(BTF_PCA_MEAN + v * image, at);
    for (int g = 0; g < BTF_PCA_GROUPS; ++g) {
      vec4 w = vec4(0.0);
      for (int i = 0; i < 3; ++i)
        w += wl.weight[i] *
             btf_texel(BTF_PCA_WEIGHTS + (v * BTF_LIGHTS + wl.index[i]) * BTF_PCA_GROUPS + g);
      for (int k = 0; k < 4; ++k)
        value += w[k] * btf_image_at(BTF_PCA_EIGEN + (v * 4 * BTF_PCA_GROUPS + 4 * g + k) * image, at);
    }
    rgb += wv.weight[j] * value;
  }
  return rgb;
}

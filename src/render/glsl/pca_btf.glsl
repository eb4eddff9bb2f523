// ---- btfgmm: PCA BTF, Koudelka et al. 2003 (src/render/glsl/pca_btf.glsl) ---------------
// An image of a measured (light, view) pair is mean + sum_k w_k(pair) eigen-image_k,
// interpolated as measured_images.glsl says. Tables: the mean image from BTF_PCA_MEAN;
// eigen-image k from BTF_PCA_EIGEN + k W H; the weights of pair p (light-major) from
// BTF_PCA_WEIGHTS + p BTF_PCA_GROUPS, four components a texel.

vec3 btf(vec2 uv, vec3 light, vec3 view) {
  BtfBilinear at = btf_bilinear(uv);
  BtfWeights wl = btf_light_weights(light), wv = btf_view_weights(view);
  int image = int(BTF_TILE.x * BTF_TILE.y);
  vec3 rgb = btf_image_at(BTF_PCA_MEAN, at);
  for (int g = 0; g < BTF_PCA_GROUPS; ++g) {
    vec4 w = vec4(0.0);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        float pw = wl.weight[i] * wv.weight[j];
        if (pw == 0.0) continue;
        int pair = wl.index[i] * BTF_VIEWS + wv.index[j];
        w += pw * btf_texel(BTF_PCA_WEIGHTS + pair * BTF_PCA_GROUPS + g);
      }
    for (int k = 0; k < 4; ++k) rgb += w[k] * btf_image_at(BTF_PCA_EIGEN + (4 * g + k) * image, at);
  }
  return rgb;
}

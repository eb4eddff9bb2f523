// ---- btfgmm: the mean BRDF (src/render/glsl/mean_brdf.glsl) ---------------------------
// The mean BRDF at any light and view (the paper's Eq. 11): the products of their weights
// over the measured directions, 9 terms. Table: ni * nv texels (r, g, b, -), light major.
vec3 btf_mean_brdf(vec3 light, vec3 view) {
  BtfWeights wl = btf_direction_weights(light, BTF_LIGHT_TRIANGLES, BTF_LIGHT_TRIANGLE_COUNT,
                                        BTF_LIGHT_EDGES, BTF_LIGHT_EDGE_COUNT);
  BtfWeights wv = btf_direction_weights(view, BTF_VIEW_TRIANGLES, BTF_VIEW_TRIANGLE_COUNT,
                                        BTF_VIEW_EDGES, BTF_VIEW_EDGE_COUNT);
  vec3 rgb = vec3(0.0);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      float w = wl.weight[a] * wv.weight[b];
      if (w == 0.0) continue;
      rgb += w * btf_texel(BTF_MEAN_BRDF + wl.index[a] * BTF_VIEWS + wv.index[b]).rgb;
    }
  return rgb;
}

// ---- btfgmm: PCA BTF, Koudelka et al. 2003 (src/render/glsl/pca_btf.glsl) ---------------
// An image of a measured (light, view) pair is mean + sum_k w_k(pair) eigen-image_k; any
// light, view and position is interpolated as methods/measured_images.hpp does: bilinear
// between the four nearest pixels (the tile wraps; integer positions at pixel centres) and
// over the measured directions with their barycentric weights (3 lights x 3 views). Tables:
// the mean image (r, g, b, -) per pixel from BTF_PCA_MEAN, row-major; eigen-image k from
// BTF_PCA_EIGEN + k W H, likewise; the weights of pair p (light-major) from
// BTF_PCA_WEIGHTS + p BTF_PCA_GROUPS, four components a texel.

vec3 btf(vec2 uv, vec3 light, vec3 view) {
  vec2 xy = btf_tile_position(uv);
  ivec2 tile = ivec2(BTF_TILE);
  ivec2 a = ivec2(floor(xy)) % tile;
  ivec2 b = (a + 1) % tile;
  vec2 f = xy - floor(xy);
  ivec4 px = ivec4(a.y * tile.x + a.x, a.y * tile.x + b.x, b.y * tile.x + a.x, b.y * tile.x + b.x);
  vec4 bw = vec4((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
  BtfWeights wl = btf_direction_weights(light, BTF_LIGHT_TRIANGLES, BTF_LIGHT_TRIANGLE_COUNT,
                                        BTF_LIGHT_EDGES, BTF_LIGHT_EDGE_COUNT);
  BtfWeights wv = btf_direction_weights(view, BTF_VIEW_TRIANGLES, BTF_VIEW_TRIANGLE_COUNT,
                                        BTF_VIEW_EDGES, BTF_VIEW_EDGE_COUNT);
  vec3 rgb = vec3(0.0);
  for (int c = 0; c < 4; ++c) rgb += bw[c] * btf_texel(BTF_PCA_MEAN + px[c]).rgb;
  for (int g = 0; g < BTF_PCA_GROUPS; ++g) {
    vec4 w = vec4(0.0);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        float pw = wl.weight[i] * wv.weight[j];
        if (pw == 0.0) continue;
        int pair = wl.index[i] * BTF_VIEWS + wv.index[j];
        w += pw * btf_texel(BTF_PCA_WEIGHTS + pair * BTF_PCA_GROUPS + g);
      }
    for (int k = 0; k < 4; ++k) {
      int e = BTF_PCA_EIGEN + (4 * g + k) * tile.x * tile.y;
      vec3 v = vec3(0.0);
      for (int c = 0; c < 4; ++c) v += bw[c] * btf_texel(e + px[c]).rgb;
      rgb += w[k] * v;
    }
  }
  return rgb;
}

// ---- btfgmm: images of the measured pairs (src/render/glsl/measured_images.glsl) ---------
// The methods that store images of the measured (light, view) pairs are interpolated as
// methods/measured_images.hpp does: bilinear between the four nearest pixels (the tile wraps;
// integer positions at pixel centres) and over the measured directions with their barycentric
// weights (3 lights x 3 views: btf_direction_weights). An image is W H texels (r, g, b, -),
// row-major.

// The image that begins at texel `image`, at the position of `b`.
vec3 btf_image_at(int image, BtfBilinear b) {
  vec3 rgb = vec3(0.0);
  for (int c = 0; c < 4; ++c) rgb += b.weight[c] * btf_texel(image + b.pixel[c]).rgb;
  return rgb;
}

BtfWeights btf_light_weights(vec3 light) {
  return btf_direction_weights(light, BTF_LIGHT_TRIANGLES, BTF_LIGHT_TRIANGLE_COUNT,
                               BTF_LIGHT_EDGES, BTF_LIGHT_EDGE_COUNT);
}
BtfWeights btf_view_weights(vec3 view) {
  return btf_direction_weights(view, BTF_VIEW_TRIANGLES, BTF_VIEW_TRIANGLE_COUNT,
                               BTF_VIEW_EDGES, BTF_VIEW_EDGE_COUNT);
}

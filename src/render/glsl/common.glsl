// ---- btfgmm: what every method's btf() shares (src/render/glsl/common.glsl) ----------------
// The parameters are one RGBA32F texture, btf_params: texel i at
// (i % BTF_PARAMS_WIDTH, i / BTF_PARAMS_WIDTH). The constants above say where each table
// begins. Directions are unit vectors in the surface's local frame (x along the tile's
// columns, y along its rows, z the normal), as btfgmm's renderer hands them to the model.

uniform highp sampler2D btf_params;

vec4 btf_texel(int i) {
  return texelFetch(btf_params, ivec2(i % BTF_PARAMS_WIDTH, i / BTF_PARAMS_WIDTH), 0);
}

// A tile position in pixels, the tile repeated: uv in tiles (1.0 = one tile) wrapped into
// [0, W) x [0, H).
vec2 btf_tile_position(vec2 uv) {
  vec2 p = uv * BTF_TILE;
  p -= BTF_TILE * floor(p / BTF_TILE);
  return vec2(p.x < 0.0 || p.x >= BTF_TILE.x ? 0.0 : p.x, p.y < 0.0 || p.y >= BTF_TILE.y ? 0.0 : p.y);
}

// The signed onion-slice angles (alpha, beta) of a direction in radians
// (core/directions.hpp): alpha = atan2(y, z), beta = asin(x).
vec2 btf_onion_slice(vec3 d) {
  vec3 n = d / length(d);
  return vec2(atan(n.y, n.z), asin(clamp(n.x, -1.0, 1.0)));
}

// ---- Interpolation over the measured directions (core/interpolation.hpp) ----------------
// Barycentric weights in a Delaunay triangulation of the measured directions projected onto
// the disk (x, y) = sin(theta) (cos phi, sin phi): the triangle whose smallest weight is the
// largest; outside the triangulation, the nearest point on its boundary edges. A triangle is
// three texels: its corners (ax, ay, bx, by), (cx, cy, -, -) and their indices (i, j, k, -);
// an edge two: (ax, ay, bx, by) and (i, j, -, -).

struct BtfWeights {
  ivec3 index;
  vec3 weight;
};

BtfWeights btf_direction_weights(vec3 d, int triangles, int triangle_count, int edges,
                                 int edge_count) {
  float z = max(d.z, 0.0);
  float len = sqrt(d.x * d.x + d.y * d.y + z * z);
  vec2 q = len > 0.0 ? d.xy / len : vec2(0.0);
  float best_min = -3.0e38;
  int best = -1;
  vec3 w = vec3(1.0, 0.0, 0.0);
  for (int k = 0; k < triangle_count; ++k) {
    vec4 ab = btf_texel(triangles + 3 * k);
    vec2 c = btf_texel(triangles + 3 * k + 1).xy;
    float area = (ab.z - ab.x) * (c.y - ab.y) - (ab.w - ab.y) * (c.x - ab.x);
    float wa = ((ab.z - q.x) * (c.y - q.y) - (ab.w - q.y) * (c.x - q.x)) / area;
    float wb = ((c.x - q.x) * (ab.y - q.y) - (c.y - q.y) * (ab.x - q.x)) / area;
    float m = min(min(wa, wb), 1.0 - wa - wb);
    if (m > best_min) {
      best_min = m;
      best = k;
      w = vec3(wa, wb, 1.0 - wa - wb);
    }
  }
  BtfWeights r;
  r.index = best >= 0 ? ivec3(btf_texel(triangles + 3 * best + 2).xyz) : ivec3(0);
  r.weight = w;
  // Outside (beyond float round-off): the nearest point on the boundary edges.
  if (best_min < -1.0e-5) {
    float best_d = 3.0e38;
    for (int k = 0; k < edge_count; ++k) {
      vec4 ab = btf_texel(edges + 2 * k);
      vec2 e = ab.zw - ab.xy;
      float len2 = dot(e, e);
      float s = len2 > 0.0 ? clamp(dot(q - ab.xy, e) / len2, 0.0, 1.0) : 0.0;
      vec2 p = ab.xy + s * e - q;
      float d2 = dot(p, p);
      if (d2 < best_d) {
        best_d = d2;
        ivec2 ij = ivec2(btf_texel(edges + 2 * k + 1).xy);
        r.index = ivec3(ij.x, ij.y, ij.x);
        r.weight = vec3(1.0 - s, s, 0.0);
      }
    }
  }
  r.weight = max(r.weight, vec3(0.0));
  r.weight /= r.weight.x + r.weight.y + r.weight.z;
  return r;
}

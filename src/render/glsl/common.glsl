// ---- btfgmm: what every method's btf() shares (src/render/glsl/common.glsl) ----------------
// The parameters are one RGBA32F texture, btf_params: texel i at
// (i % BTF_PARAMS_WIDTH, i / BTF_PARAMS_WIDTH). The constants above say where each table
// begins. Directions are unit vectors in the surface's local frame (x along the tile's
// columns, y along its rows, z the normal), as btfgmm's renderer hands them to the model.

uniform highp sampler2D btf_params;

vec4 btf_texel(int i) {
  return texelFetch(btf_params, ivec2(i % BTF_PARAMS_WIDTH, i / BTF_PARAMS_WIDTH), 0);
}

// The tables are records of 2 or 4 texels, each table beginning at a multiple of its record's
// size, so that a record lies in one row: its position found once (btf_at), its texels
// fetched beside it (btf_fetch), the next record's position stepped to (btf_next).
ivec2 btf_at(int i) {
  return ivec2(i % BTF_PARAMS_WIDTH, i / BTF_PARAMS_WIDTH);
}
vec4 btf_fetch(ivec2 at, int k) {
  return texelFetch(btf_params, ivec2(at.x + k, at.y), 0);
}
ivec2 btf_next(ivec2 at, int n) {
  return at.x + n < BTF_PARAMS_WIDTH ? ivec2(at.x + n, at.y) : ivec2(0, at.y + 1);
}

// A tile position in pixels, the tile repeated: uv in tiles (1.0 = one tile) wrapped into
// [0, W) x [0, H).
vec2 btf_tile_position(vec2 uv) {
  vec2 p = uv * BTF_TILE;
  p -= BTF_TILE * floor(p / BTF_TILE);
  return vec2(p.x < 0.0 || p.x >= BTF_TILE.x ? 0.0 : p.x, p.y < 0.0 || p.y >= BTF_TILE.y ? 0.0 : p.y);
}

// The four pixels around a tile position and their bilinear weights (integer positions at
// pixel centres, the tile wraps).
struct BtfBilinear {
  ivec4 pixel;    // the four nearest pixels' indices: (x0, y0), (x1, y0), (x0, y1), (x1, y1)
  vec4 weight;
};

BtfBilinear btf_bilinear(vec2 uv) {
  vec2 xy = btf_tile_position(uv);
  ivec2 tile = ivec2(BTF_TILE);
  ivec2 a = ivec2(floor(xy)) % tile;
  ivec2 b = (a + 1) % tile;
  vec2 f = xy - floor(xy);
  BtfBilinear r;
  r.pixel = ivec4(a.y * tile.x + a.x, a.y * tile.x + b.x, b.y * tile.x + a.x, b.y * tile.x + b.x);
  r.weight = vec4((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
  return r;
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
// four texels: its corners and the inverse of its signed area, (ax, ay, bx, by) and
// (cx, cy, 1 / A, -), its corners' indices (i, j, k, -), and one unused; an edge is two:
// (ax, ay, bx, by) and (i, j, -, -).

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
  ivec2 best = ivec2(-1);
  vec3 w = vec3(1.0, 0.0, 0.0);
  ivec2 at = btf_at(triangles);
  for (int k = 0; k < triangle_count; ++k, at = btf_next(at, 4)) {
    vec4 ab = btf_fetch(at, 0);
    vec3 c = btf_fetch(at, 1).xyz;
    float wa = ((ab.z - q.x) * (c.y - q.y) - (ab.w - q.y) * (c.x - q.x)) * c.z;
    float wb = ((c.x - q.x) * (ab.y - q.y) - (c.y - q.y) * (ab.x - q.x)) * c.z;
    float m = min(min(wa, wb), 1.0 - wa - wb);
    if (m > best_min) {
      best_min = m;
      best = at;
      w = vec3(wa, wb, 1.0 - wa - wb);
    }
  }
  BtfWeights r;
  r.index = best.x >= 0 ? ivec3(btf_fetch(best, 2).xyz) : ivec3(0);
  r.weight = w;
  // Outside (beyond float round-off): the nearest point on the boundary edges.
  if (best_min < -1.0e-5) {
    float best_d = 3.0e38;
    ivec2 at = btf_at(edges);
    for (int k = 0; k < edge_count; ++k, at = btf_next(at, 2)) {
      vec4 ab = btf_fetch(at, 0);
      vec2 e = ab.zw - ab.xy;
      float len2 = dot(e, e);
      float s = len2 > 0.0 ? clamp(dot(q - ab.xy, e) / len2, 0.0, 1.0) : 0.0;
      vec2 p = ab.xy + s * e - q;
      float d2 = dot(p, p);
      if (d2 < best_d) {
        best_d = d2;
        ivec2 ij = ivec2(btf_fetch(at, 1).xy);
        r.index = ivec3(ij.x, ij.y, ij.x);
        r.weight = vec3(1.0 - s, s, 0.0);
      }
    }
  }
  r.weight = max(r.weight, vec3(0.0));
  r.weight /= r.weight.x + r.weight.y + r.weight.z;
  return r;
}

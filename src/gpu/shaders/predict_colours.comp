#version 450
// The conditional expectation of the colour, Eq. (8)-(10), on the device for decode and eval
// (src/model/predict_gpu.cpp), the sum predict.cpp and decode.cpp make on the CPU: per query
// the exponents t_m (log_weight_base and the six terms -d^2 / (2 sigma^2) of Eq. 2, x and y
// in the minimum image, as refine_tables.comp makes them), the weights exp(t_m - max) of
// Eq. (9) and the colour sum e mu / sum e, in one pass over the components in their order:
// the sums are rescaled when a larger exponent comes. Eq. (11)'s unit and mean BRDF are the
// host's. One invocation a query: on the grid (decode), query i is pixel i % pixels of image
// i / pixels, the images light-major; otherwise (eval) query i has row i of each input.
layout(local_size_x = 64) in;

// Per component 5 vec4, as refine_tables.comp reads them: (mu_6..8, 0), (mu_0, mu_1,
// 1/sigma^2_0, 1/sigma^2_1), the same of the view's angles (inputs 4, 5), the same of the
// light's (inputs 2, 3), (log_weight_base, 0, 0, 0).
layout(std430, binding = 0) readonly buffer Components { vec4 comp[]; };
layout(std430, binding = 1) readonly buffer PixelPositions { vec2 pixel_xy[]; };
layout(std430, binding = 2) readonly buffer LightAngles { vec2 light_ab[]; };
layout(std430, binding = 3) readonly buffer ViewAngles { vec2 view_ab[]; };
layout(std430, binding = 4) writeonly buffer Colours { float colour[]; };

layout(push_constant) uniform Push {
  uint components, pixels, views, grid, first, count;
  float period_x, period_y;
} pc;

// -d^2 / (2 sigma^2) of x about mean (d the minimum image where period > 0).
float term(float x, float mean, float inv_var, float period) {
  float d = x - mean;
  if (period > 0.0) d -= period * floor(d / period + 0.5);
  return -0.5 * d * d * inv_var;
}

float pair_terms(vec2 x, vec4 in_put, vec2 period) {
  return term(x.x, in_put.x, in_put.z, period.x) + term(x.y, in_put.y, in_put.w, period.y);
}

void main() {
  const uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 64 +
                 gl_LocalInvocationID.x;
  if (i >= pc.count) return;
  const uint q = pc.first + i;
  uint p = q, l = q, v = q;
  if (pc.grid != 0) {
    p = q % pc.pixels;
    const uint image = q / pc.pixels;
    l = image / pc.views;
    v = image % pc.views;
  }
  const vec2 xy = pixel_xy[p], la = light_ab[l], va = view_ab[v];
  const vec2 periods = vec2(pc.period_x, pc.period_y);
  float largest = -1e38, sum = 0.0;
  vec3 c = vec3(0.0);
  for (uint k = 0; k < pc.components; ++k) {
    const float t = comp[5 * k + 4].x + pair_terms(xy, comp[5 * k + 1], periods) +
                    pair_terms(va, comp[5 * k + 2], vec2(0.0)) +
                    pair_terms(la, comp[5 * k + 3], vec2(0.0));
    const vec3 mu = comp[5 * k].xyz;
    if (t > largest) {
      const float r = exp(largest - t);
      sum = sum * r + 1.0;
      c = c * r + mu;
      largest = t;
    } else {
      const float e = exp(t - largest);
      sum += e;
      c += e * mu;
    }
  }
  c /= sum;
  colour[3 * i] = c.x;
  colour[3 * i + 1] = c.y;
  colour[3 * i + 2] = c.z;
}

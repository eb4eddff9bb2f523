#version 450
// The parts of the exponents t_m of Eq. (9)-(10) on the sample grid (grid_weights.hpp,
// exponent_parts) made on the device for the fit for the prediction (src/model/refine_gpu.cpp):
// a pixel's (log_weight_base and the terms of x and y, the minimum image), a light's and a
// view's (the terms of their two angles), each term -d^2 / (2 sigma^2) of Eq. (2), row-major
// (a row's components side by side) and column-major (a component's rows side by side). One
// invocation a (row, component), the pixels' rows first, then the lights', then the views'.
layout(local_size_x = 256) in;

// Per component 5 vec4: (mu_6..8, 0), (mu_0, mu_1, 1/sigma^2_0, 1/sigma^2_1), the same of
// the view's angles (inputs 4, 5), the same of the light's (inputs 2, 3), (log_weight_base,
// 0, 0, 0).
layout(std430, binding = 0) readonly buffer Components { vec4 comp[]; };
layout(std430, binding = 1) readonly buffer LightAngles { vec2 light_ab[]; };
layout(std430, binding = 2) readonly buffer ViewAngles { vec2 view_ab[]; };
layout(std430, binding = 3) writeonly buffer PixelRows { float pixel_r[]; };
layout(std430, binding = 4) writeonly buffer LightRows { float light_r[]; };
layout(std430, binding = 5) writeonly buffer ViewRows { float view_r[]; };
layout(std430, binding = 6) writeonly buffer PixelColumns { float pixel_t[]; };
layout(std430, binding = 7) writeonly buffer LightColumns { float light_t[]; };
layout(std430, binding = 8) writeonly buffer ViewColumns { float view_t[]; };

layout(push_constant) uniform Push {
  uint components, pixels, lights, views, width;
  float period_x, period_y;
} pc;

// -d^2 / (2 sigma^2) of x about mean (d the minimum image where period > 0).
float term(float x, float mean, float inv_var, float period) {
  float d = x - mean;
  if (period > 0.0) d -= period * floor(d / period + 0.5);
  return -0.5 * d * d * inv_var;
}

// The two terms of a pair of inputs (mu_a, mu_b, 1/sigma^2_a, 1/sigma^2_b) at (a, b).
float pair_terms(vec2 x, vec4 in_put) {
  return term(x.x, in_put.x, in_put.z, 0.0) + term(x.y, in_put.y, in_put.w, 0.0);
}

void main() {
  const uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 256 +
                 gl_LocalInvocationID.x;
  const uint m = pc.components, rows = pc.pixels + pc.lights + pc.views;
  if (i >= rows * m) return;
  const uint r = i / m, k = i % m;
  if (r < pc.pixels) {
    const vec4 sp = comp[5 * k + 1];
    const float t = comp[5 * k + 4].x + term(float(r % pc.width), sp.x, sp.z, pc.period_x) +
                    term(float(r / pc.width), sp.y, sp.w, pc.period_y);
    pixel_r[r * m + k] = t;
    pixel_t[k * pc.pixels + r] = t;
  } else if (r < pc.pixels + pc.lights) {
    const uint l = r - pc.pixels;
    const float t = pair_terms(light_ab[l], comp[5 * k + 3]);
    light_r[l * m + k] = t;
    light_t[k * pc.lights + l] = t;
  } else {
    const uint v = r - pc.pixels - pc.lights;
    const float t = pair_terms(view_ab[v], comp[5 * k + 2]);
    view_r[v * m + k] = t;
    view_t[k * pc.views + v] = t;
  }
}

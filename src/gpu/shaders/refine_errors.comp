#version 450
// The fit for the prediction on a compute device, first half (src/model/refine_gpu.cpp): for
// every sample of a selection its conditional weights W_m = exp(t_m - mx) / sum (Eq. 9), t_m
// the sum of the pixel's, light's and view's parts (grid_weights.hpp, exponent_parts), the
// prediction yhat = sum_m W_m mu_m,6+c (Eq. 8, in one pass with the softmax), its error
// e = r - yhat and e . yhat; per workgroup of one light the samples' squared errors and their
// count, in double, by a tree of fixed shape.
// A slot is (held light lh, pixel p, i): the view v = start + i modulus, the pixel's i-th of
// the selection ((p + l nv + v) mod modulus = residue), taken where v < nv and its part holds
// (0 every sample, 1 the training samples, 2 the held-out ones). One invocation a slot; a
// light's slots fill whole workgroups of their own (groups_per_light).
layout(local_size_x = 256) in;

// The parts of t_m, column-major (a component's pixels, lights, views side by side).
layout(std430, binding = 0) readonly buffer PixelParts { float pixel_t[]; };
layout(std430, binding = 1) readonly buffer LightParts { float light_t[]; };
layout(std430, binding = 2) readonly buffer ViewParts { float view_t[]; };
// Per component 5 vec4, the first (mu_6..8, 0) (refine_tables.comp).
layout(std430, binding = 3) readonly buffer Components { vec4 comp[]; };
// Per sample (held light, pixel, view) its residual colour (r, g, b, 0) and a bit: held out.
layout(std430, binding = 4) readonly buffer Residuals { vec4 residual[]; };
layout(std430, binding = 5) readonly buffer HeldOut { uint held_out[]; };
// Per slot: (e, e . yhat) and (mx, 1 / sum, the view (exact in float), 0); 1 / sum = 0 where
// no sample.
layout(std430, binding = 6) writeonly buffer Slots { vec4 slot[]; };
layout(std430, binding = 7) writeonly buffer GroupErrors { dvec2 group_errors[]; };

layout(push_constant) uniform Push {
  uint components, pixels, lights, views, held, first_light, modulus, residue, part, slots,
      groups_per_light;
} pc;

shared dvec2 terms[256];

bool in_part(uint n) {
  if (pc.part == 0) return true;
  const bool is_held = ((held_out[n >> 5] >> (n & 31)) & 1) != 0;
  return is_held == (pc.part == 2);
}

void main() {
  const uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
  const uint lh = group / pc.groups_per_light;
  const uint i = (group % pc.groups_per_light) * 256 + gl_LocalInvocationID.x;
  dvec2 term = dvec2(0.0);
  if (lh < pc.held && i < pc.pixels * pc.slots) {
    const uint p = i / pc.slots, l = pc.first_light + lh;
    const uint start = (pc.residue + pc.modulus - (p + l * pc.views) % pc.modulus) % pc.modulus;
    const uint v = start + (i % pc.slots) * pc.modulus;
    const uint n = (lh * pc.pixels + p) * pc.views + v;
    const uint at = 2 * (lh * pc.pixels * pc.slots + i);
    if (v < pc.views && in_part(n)) {
      float mx = -1.0 / 0.0, sum = 0.0;
      vec3 y = vec3(0.0);
      for (uint k = 0; k < pc.components; ++k) {
        const float t = pixel_t[k * pc.pixels + p] + light_t[k * pc.lights + l] +
                        view_t[k * pc.views + v];
        const vec3 mu = comp[5 * k].xyz;
        if (t > mx) {
          const float scale = exp(mx - t);
          sum = sum * scale + 1.0;
          y = y * scale + mu;
          mx = t;
        } else {
          const float w = exp(t - mx);
          sum += w;
          y += w * mu;
        }
      }
      const float inv = 1.0 / sum;
      const vec3 yhat = y * inv;
      const vec3 e = residual[n].xyz - yhat;
      slot[at] = vec4(e, dot(e, yhat));
      slot[at + 1] = vec4(mx, inv, float(v), 0.0);
      term = dvec2(double(e.x) * double(e.x) + double(e.y) * double(e.y) +
                       double(e.z) * double(e.z),
                   1.0);
    } else if (i < pc.pixels * pc.slots) {
      slot[at] = vec4(0.0);
      slot[at + 1] = vec4(0.0);
    }
  }
  terms[gl_LocalInvocationID.x] = term;
  barrier();
  for (uint half_size = 128; half_size > 0; half_size /= 2) {
    if (gl_LocalInvocationID.x < half_size)
      terms[gl_LocalInvocationID.x] += terms[gl_LocalInvocationID.x + half_size];
    barrier();
  }
  if (gl_LocalInvocationID.x == 0 && lh < pc.held) group_errors[group] = terms[0];
}

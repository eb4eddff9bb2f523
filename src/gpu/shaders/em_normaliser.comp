#version 450
// The E pass, first half (src/model/em_gpu.cpp): for every sample its largest log density
// over the components and the inverse of sum_m exp(log density - largest), Eq. (4)'s
// normaliser, and the workgroup's sum of the samples' terms of L, Eq. (3) (mx + log sum), in
// double, by a tree of fixed shape. One invocation a sample; a light's samples fill whole
// workgroups of their own (groups_per_light), so each workgroup's sum belongs to one light.
layout(local_size_x = 256) in;

#include "em_common.glsl"

layout(std430, binding = 5) writeonly buffer Normaliser { vec2 normaliser[]; };  // mx, 1 / sum
layout(std430, binding = 6) writeonly buffer GroupTerms { double group_terms[]; };

layout(push_constant) uniform Push {
  uint stride, components, pixels, views, held, first_light, groups_per_light;
} pc;

shared double terms[256];

void main() {
  const uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
  const uint lh = group / pc.groups_per_light;
  const uint i = (group % pc.groups_per_light) * 256 + gl_LocalInvocationID.x;
  double term = 0.0;
  if (lh < pc.held && i < pc.pixels * pc.views) {
    const uint p = i / pc.views, v = i % pc.views;
    const uint n = lh * pc.pixels * pc.views + i;
    const vec3 r = residual_of(n);
    const uint srow = p * pc.stride, lrow = (pc.first_light + lh) * pc.stride;
    float mx = -1.0 / 0.0, sum = 0.0;
    for (uint k = 0; k < pc.components; ++k) {
      const float sl = s_table[srow + k] + l_table[lrow + k];
      const float t = log_density(sl, v_table[k * pc.views + v], r - colour_mean(k),
                                  colour_h(k));
      if (t > mx) {
        sum = sum * exp(mx - t) + 1.0;
        mx = t;
      } else {
        sum += exp(t - mx);
      }
    }
    normaliser[n] = vec2(mx, 1.0 / sum);
    term = double(mx) + double(log(sum));
  }
  terms[gl_LocalInvocationID.x] = term;
  barrier();
  for (uint half_size = 128; half_size > 0; half_size /= 2) {
    if (gl_LocalInvocationID.x < half_size)
      terms[gl_LocalInvocationID.x] += terms[gl_LocalInvocationID.x + half_size];
    barrier();
  }
  if (gl_LocalInvocationID.x == 0 && lh < pc.held) group_terms[group] = terms[0];
}

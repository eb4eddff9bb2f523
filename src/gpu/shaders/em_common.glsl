// What the E pass's shaders share (em_normaliser.comp, em_statistics.comp): the tables of one
// iteration of the grid EM (src/model/em_tables.cpp, made on the CPU) and the samples.
// log w_m F(x | m), Eq. (2), of component column k for sample (pixel p, light l, view v) is
//   S[p][k] + L[l][k] + V[v][k] + sum_c h_c[k] (r_c - mu_c[k])^2,   h = -1 / (2 sigma^2)
// with the residual colour r of the sample (src/model/em.cpp, "The grid path").
// Samples are held light-major: sample (held light lh, pixel p, view v) is (lh P + p) nv + v.

layout(std430, binding = 0) readonly buffer SpatialTable { float s_table[]; };   // P x stride
layout(std430, binding = 1) readonly buffer LightTable { float l_table[]; };     // ni x stride
// V: em_normaliser.comp binds it column-major (stride x nv: a column's views side by side),
// em_statistics.comp view-major (nv x stride: a view's columns side by side), each as its
// workgroups read it.
layout(std430, binding = 2) readonly buffer ViewTable { float v_table[]; };
// Per column k: colour[2k] = (mu_r, mu_g, mu_b, 0), colour[2k + 1] = (h_r, h_g, h_b, 0).
layout(std430, binding = 3) readonly buffer ColourTable { vec4 colour[]; };
// Per sample its residual colour (r, g, b, 0).
layout(std430, binding = 4) readonly buffer Residuals { vec4 residual[]; };

// The colour means and h = -1 / (2 sigma^2) of column k.
vec3 colour_mean(uint k) {
  return colour[2 * k].xyz;
}
vec3 colour_h(uint k) {
  return colour[2 * k + 1].xyz;
}

// Eq. (2) of a column for a sample: its S + L term `sl`, its V term `vt`, and its colour's
// distance d to the column's means.
float log_density(float sl, float vt, vec3 d, vec3 h) {
  return sl + vt + h.x * d.x * d.x + h.y * d.y * d.y + h.z * d.z * d.z;
}

vec3 residual_of(uint n) {
  return residual[n].xyz;
}

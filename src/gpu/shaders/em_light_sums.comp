#version 450
// The E pass's chunks of one light added in chunk order (src/model/em_gpu.cpp): the light's
// 15 rows of stride doubles (em_statistics.comp), one invocation a number.
layout(local_size_x = 256) in;

layout(std430, binding = 0) readonly buffer ChunkSums { double chunk_sums[]; };
layout(std430, binding = 1) writeonly buffer LightSums { double light_sums[]; };

layout(push_constant) uniform Push { uint per_chunk, chunks, held; } pc;

void main() {
  const uint i = gl_GlobalInvocationID.x, lh = gl_WorkGroupID.y;
  if (i >= pc.per_chunk || lh >= pc.held) return;
  double sum = 0.0;
  for (uint c = 0; c < pc.chunks; ++c) sum += chunk_sums[(lh * pc.chunks + c) * pc.per_chunk + i];
  light_sums[lh * pc.per_chunk + i] = sum;
}

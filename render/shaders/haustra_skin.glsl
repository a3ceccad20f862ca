// haustra's skinning in a vertex shader (GLSL 3.30 core; decision 0110, docs/skinning.md "Skinning on the host's GPU").
// No #version line: a host puts "#version 330 core" (or later) before this text and its own main()
// after it. Buffers (texture buffers, GL 3.1+, no SSBO needed), from haustra_world_gpu_skin
// (World::gpu_skin_binding) once and haustra_world_gpu_rings (World::gpu_ring_frame) each frame:
//   haustra_rings         RGBA32F, 6 texels a ring: rows of [R' - R | c' - c], then of [(R' - R) R^T | 0]
//   haustra_coefficients  RGBA32F, 1 texel a slot: b, Ax, Ay, Az
//   haustra_slot_rings    R32UI,   1 texel a slot: its ring
// and per vertex the attributes rest position, rest normal and (first slot, slot count) as a uvec2
// (glVertexAttribIPointer). It is the CPU's sum, x' = x + sum_s [dR_g A_s + b_s dc_g], in float.
uniform samplerBuffer haustra_rings;
uniform samplerBuffer haustra_coefficients;
uniform usamplerBuffer haustra_slot_rings;

// position: the skinned vertex; normal: the rest normal under the cofactor of
// M = I + sum_s b_s (R'_g - R_g) R_g^T (the rings' rotations blended by weight), normalized; zero
// when the rest normal is zero (a vertex of no triangle, or a mesh without normals).
void haustra_skin(vec3 rest_position, vec3 rest_normal, uvec2 slots, out vec3 position, out vec3 normal) {
  vec3 d = vec3(0.0);
  vec3 m0 = vec3(1.0, 0.0, 0.0), m1 = vec3(0.0, 1.0, 0.0), m2 = vec3(0.0, 0.0, 1.0);  // rows of M
  for (uint s = slots.x; s < slots.x + slots.y; ++s) {
    int g = 6 * int(texelFetch(haustra_slot_rings, int(s)).r);
    vec4 c = texelFetch(haustra_coefficients, int(s));
    vec4 a = vec4(c.yzw, c.x);  // Ax Ay Az b against a row [dR | dc]
    d += vec3(dot(texelFetch(haustra_rings, g), a), dot(texelFetch(haustra_rings, g + 1), a),
              dot(texelFetch(haustra_rings, g + 2), a));
    m0 += c.x * texelFetch(haustra_rings, g + 3).xyz;
    m1 += c.x * texelFetch(haustra_rings, g + 4).xyz;
    m2 += c.x * texelFetch(haustra_rings, g + 5).xyz;
  }
  position = rest_position + d;
  vec3 n = vec3(dot(cross(m1, m2), rest_normal), dot(cross(m2, m0), rest_normal), dot(cross(m0, m1), rest_normal));
  float len = length(n);
  normal = len > 0.0 ? n / len : vec3(0.0);
}

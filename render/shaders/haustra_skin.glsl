// haustra's skinning in a vertex shader (GLSL 3.30 core; decisions 0110, 0122, docs/skinning.md "Skinning on the host's GPU").
// No #version line: a host puts "#version 330 core" (or later) before this text and its own main()
// after it. Buffers (texture buffers, GL 3.1+, no SSBO needed), from haustra_world_gpu_skin
// (World::gpu_skin_binding) once and haustra_world_gpu_rings (World::gpu_ring_frame) each frame:
//   haustra_rings         RGBA32F, 6 texels a ring: rows of [R' - R | c' - c], then of [(R' - R) R^T | 0];
//                         then 6 texels a ring more: the along-rod screws (decision 0122), for a
//                         station the screw to the next: [R | c] (3 rows), [axis | angle], [P | c], [Q | d]
//   haustra_coefficients  RGBA32F, 1 texel a slot: b, Ax, Ay, Az (a screw: two, (t, o) and (w, n))
//   haustra_slot_rings    R32UI,   1 texel a slot: its ring (top bit set: a screw, at that texel row / 6)
// and per vertex the attributes rest position, rest normal and (first slot, slot count) as a uvec2
// (glVertexAttribIPointer). It is the CPU's sum, x' = x + sum_s [dR_g A_s + b_s dc_g], or along the
// rod its screw x' = sum w T(t) o, in float.
uniform samplerBuffer haustra_rings;
uniform samplerBuffer haustra_coefficients;
uniform usamplerBuffer haustra_slot_rings;

// sin(p) / p and (1 - cos(p)) / p^2 of x = p^2: Taylor polynomials through p^14, coefficients from
// the highest power down, summed by one Horner rule (as the CPU's kernel): no division, so no
// branch as the screw's angle goes to zero.
const float haustra_sinc_terms[8] = float[8](-1.0 / 1307674368000.0, 1.0 / 6227020800.0, -1.0 / 39916800.0,
                                             1.0 / 362880.0, -1.0 / 5040.0, 1.0 / 120.0, -1.0 / 6.0, 1.0);
const float haustra_cosc_terms[8] = float[8](-1.0 / 20922789888000.0, 1.0 / 87178291200.0, -1.0 / 479001600.0,
                                             1.0 / 3628800.0, -1.0 / 40320.0, 1.0 / 720.0, -1.0 / 24.0, 0.5);
float haustra_horner(float x, const float c[8]) {
  float r = c[0];
  for (int i = 1; i < 8; ++i) r = r * x + c[i];
  return r;
}

// The screw at texel g at fraction t: o (a point in its rest frame) to position, n to normal.
void haustra_screw(int g, float t, vec3 o, vec3 n, out vec3 position, out vec3 normal) {
  vec4 r0 = texelFetch(haustra_rings, g), r1 = texelFetch(haustra_rings, g + 1), r2 = texelFetch(haustra_rings, g + 2);
  vec4 w = texelFetch(haustra_rings, g + 3), p = texelFetch(haustra_rings, g + 4), q = texelFetch(haustra_rings, g + 5);
  float phi = t * w.w, phi2 = phi * phi;
  float sc = haustra_horner(phi2, haustra_sinc_terms), cc = haustra_horner(phi2, haustra_cosc_terms);
  float sn = phi * sc, omc = phi2 * cc, tc = t * p.w;
  float kp = 0.5 * omc + tc * sc, kq = phi * (tc * cc - 0.5 * sc);
  vec3 a = cross(w.xyz, o), b = cross(w.xyz, n);
  vec3 y = o + sn * a + omc * cross(w.xyz, a) + kp * p.xyz + kq * q.xyz + (t * q.w) * w.xyz;
  vec3 m = n + sn * b + omc * cross(w.xyz, b);
  position = vec3(dot(r0.xyz, y), dot(r1.xyz, y), dot(r2.xyz, y)) + vec3(r0.w, r1.w, r2.w);
  normal = vec3(dot(r0.xyz, m), dot(r1.xyz, m), dot(r2.xyz, m));
}

// position: the skinned vertex; normal: the rest normal under the cofactor of
// M = I + sum_s b_s (R'_g - R_g) R_g^T (the rings' rotations blended by weight), or along the rod
// turned by the screw's rotation, normalized; zero when the rest normal is zero (a vertex of no
// triangle, or a mesh without normals).
void haustra_skin(vec3 rest_position, vec3 rest_normal, uvec2 slots, out vec3 position, out vec3 normal) {
  vec3 d = vec3(0.0);
  vec3 m0 = vec3(1.0, 0.0, 0.0), m1 = vec3(0.0, 1.0, 0.0), m2 = vec3(0.0, 0.0, 1.0);  // rows of M
  vec3 screw_position = vec3(0.0), screw_normal = vec3(0.0);
  bool screw = false;
  for (uint s = slots.x; s < slots.x + slots.y; ++s) {
    uint ring = texelFetch(haustra_slot_rings, int(s)).r;
    vec4 c = texelFetch(haustra_coefficients, int(s));
    if (ring >= 0x80000000u) {  // a screw: (t, o) here, (w, n) in the next slot
      vec4 e = texelFetch(haustra_coefficients, int(s) + 1);
      vec3 sp, sn;
      haustra_screw(6 * int(ring - 0x80000000u), c.x, c.yzw, e.yzw, sp, sn);
      screw_position += e.x * sp;
      screw_normal += e.x * sn;
      screw = true;
      ++s;
      continue;
    }
    int g = 6 * int(ring);
    vec4 a = vec4(c.yzw, c.x);  // Ax Ay Az b against a row [dR | dc]
    d += vec3(dot(texelFetch(haustra_rings, g), a), dot(texelFetch(haustra_rings, g + 1), a),
              dot(texelFetch(haustra_rings, g + 2), a));
    m0 += c.x * texelFetch(haustra_rings, g + 3).xyz;
    m1 += c.x * texelFetch(haustra_rings, g + 4).xyz;
    m2 += c.x * texelFetch(haustra_rings, g + 5).xyz;
  }
  vec3 n = screw ? screw_normal
                 : vec3(dot(cross(m1, m2), rest_normal), dot(cross(m2, m0), rest_normal),
                        dot(cross(m0, m1), rest_normal));
  position = screw ? screw_position : rest_position + d;
  float len = length(n);
  normal = len > 0.0 ? n / len : vec3(0.0);
}

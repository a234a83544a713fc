"""The lines of three.js r187's shader chunks that glTF 2.0's Appendix B and
KHR_materials_clearcoat do not have, and the JavaScript that patches lines out of a
material's program: tests/test_cross_render.py and benchmarks/three_judge_page.py draw
three.js's picture with and without them (one copy of three.js's text, so that a new
three.js release is caught in both)."""

# Turquin's multiple-scattering compensation, the geometric roughness of screen-space normals
# (the base's and the coat's), the coat's Fresnel at v.h: [chunk, line, replacement, the line's
# first occurrence after this marker].
NOT_IN_SPEC_JS = r"""
const NOT_IN_SPEC = [
  ["lights_fragment_begin",
   "material.multiScatteringCompensation = 1.0 + material.specularColorBlended * ( 1.0 / EssMs - 1.0 );",
   "material.multiScatteringCompensation = vec3( 1.0 );", ""],
  ["lights_physical_fragment", "material.roughness += geometryRoughness;", "", ""],
  ["lights_physical_fragment", "material.clearcoatRoughness += geometryRoughness;", "", ""],
  ["lights_physical_pars_fragment", "vec3 F = F_Schlick( f0, f90, dotVH );",
   "vec3 F = F_Schlick( f0, f90, dotNV );", "vec3 BRDF_GGX_Clearcoat("],
];
"""

# patcher(lines): an onBeforeCompile that replaces each [chunk, line, replacement, after] in the
# program's chunks; a line three.js no longer has is an error, never a silent no-op.
PATCHER_JS = r"""
function patcher(lines) {
  return (shader) => {
    const chunks = {};
    for (const [chunk, line, replacement, after] of lines) {
      const code = chunks[chunk] ?? THREE.ShaderChunk[chunk];
      const i = code.indexOf(line, Math.max(code.indexOf(after), 0));
      if (code.indexOf(after) < 0 || i < 0) throw new Error("three.js changed: " + chunk + " has no " + line);
      chunks[chunk] = code.slice(0, i) + replacement + code.slice(i + line.length);
    }
    for (const [chunk, code] of Object.entries(chunks))
      shader.fragmentShader = shader.fragmentShader.replace("#include <" + chunk + ">", code);
  };
}
"""

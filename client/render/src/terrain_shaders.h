#pragma once

// GLSL 3.30 core sources of the terrain program. Colour by height (lowland green, upland brown,
// snow) and slope (rock on steep ground: crater walls), lit by a low sun plus sky light, with
// optional haze. In line mode a non-zero u_line_colour.a replaces the colour.

namespace terrain::render {

inline constexpr const char* kTerrainVertexShader = R"(#version 330 core
layout(location = 0) in vec3 a_position; // x, y: lattice units from the map's corner; z: metres
layout(location = 1) in vec3 a_normal;
uniform mat4 u_view_projection;          // rotation and projection, eye at the origin
uniform vec2 u_eye_whole;                // the eye in lattice units, whole part (exact)
uniform vec3 u_eye_rest;                 // the rest of it (lattice units), and its height (metres)
uniform float u_metres_per_lattice;
uniform vec2 u_clip;                     // the map's far corner, lattice units (the near one: 0, 0)
out vec3 v_normal;
out vec3 v_from_eye;
out float v_height;
// the same vertex from any draw reaches the rasterizer as the same bits: no per-draw uniform
// below, and no recomputation that may round otherwise
invariant gl_Position;
void main() {
    // whole numbers minus a whole number: exact; the fraction then rounds once
    vec2 lattice = (a_position.xy - u_eye_whole) - u_eye_rest.xy;
    vec3 p = vec3(lattice * u_metres_per_lattice, a_position.z - u_eye_rest.z);
    gl_Position = u_view_projection * vec4(p, 1.0);
    // triangles reaching into the padding beyond the map are cut at its edge
    gl_ClipDistance[0] = a_position.x;
    gl_ClipDistance[1] = u_clip.x - a_position.x;
    gl_ClipDistance[2] = a_position.y;
    gl_ClipDistance[3] = u_clip.y - a_position.y;
    v_normal = a_normal;
    v_from_eye = p;
    v_height = a_position.z;
}
)";

inline constexpr const char* kTerrainFragmentShader = R"(#version 330 core
in vec3 v_normal;
in vec3 v_from_eye;
in float v_height;
uniform vec3 u_sun;          // unit, towards the sun
uniform vec3 u_sky;
uniform float u_haze;        // 1 / haze distance (0: none)
uniform vec2 u_height_range; // lowest, highest vertex (metres)
uniform vec4 u_line_colour;
out vec4 o_colour;
void main() {
    vec3 n = normalize(v_normal);
    float t = clamp((v_height - u_height_range.x) /
                    max(u_height_range.y - u_height_range.x, 1e-3), 0.0, 1.0);
    vec3 low = vec3(0.28, 0.44, 0.20);
    vec3 mid = vec3(0.56, 0.49, 0.33);
    vec3 high = vec3(0.93, 0.93, 0.95);
    vec3 ground = t < 0.65 ? mix(low, mid, smoothstep(0.0, 0.65, t))
                           : mix(mid, high, smoothstep(0.75, 1.0, t));
    float steepness = 1.0 - n.z;
    ground = mix(ground, vec3(0.47, 0.43, 0.40), smoothstep(0.12, 0.40, steepness));
    float sun = max(dot(n, u_sun), 0.0);
    float sky = 0.30 + 0.20 * n.z;
    vec3 colour = ground * (sky + 0.85 * sun);
    if (u_line_colour.a > 0.0)
        colour = mix(colour, u_line_colour.rgb, u_line_colour.a);
    float haze = 1.0 - exp(-length(v_from_eye) * u_haze);
    o_colour = vec4(mix(colour, u_sky, haze), 1.0);
}
)";

} // namespace terrain::render

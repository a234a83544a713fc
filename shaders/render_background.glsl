// Background of the preview: the environment seen along each camera ray, with
// the discs of directional lights that have an angular size.
#include "ibl.glsl"
#include "lights.glsl"

in vec2 v_ndc;
out vec4 frag_color;

uniform vec3 camera_right;
uniform vec3 camera_up;
uniform vec3 camera_forward;     // scaled: ray = forward + x right + y up
uniform int background_mode;     // 0 environment, 1 solid colour
uniform vec3 background_color;

void main() {
    if (background_mode == 1) {
        frag_color = vec4(background_color, 0.0);
        return;
    }
    vec3 d = normalize(camera_forward + v_ndc.x * camera_right + v_ndc.y * camera_up);
    vec3 color = environment_radiance(d, 0.0);
    for (int i = 0; i < n_directional_lights; ++i) {
        float r = directional_light_radius[i];
        if (r > 0.0 && dot(d, directional_light_direction[i]) > cos(r)) {
            // uniform disc of solid angle 2 pi (1 - cos r) with the light's irradiance
            color += directional_light_irradiance[i] / (2.0 * PI * (1.0 - cos(r)));
        }
    }
    frag_color = vec4(color, 0.0);
}

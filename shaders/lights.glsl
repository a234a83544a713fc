// Analytic lights of the preview renderer (shaders/scene.py fills them; it
// reads MAX_LIGHTS from this file).
const int MAX_LIGHTS = 8;
uniform int n_point_lights;
uniform vec3 point_light_position[MAX_LIGHTS];
uniform vec3 point_light_intensity[MAX_LIGHTS];     // W/sr; irradiance I cos / d^2
uniform int n_directional_lights;
uniform vec3 directional_light_direction[MAX_LIGHTS];   // towards the light, unit
uniform vec3 directional_light_irradiance[MAX_LIGHTS];  // W/m^2 facing the light
uniform float directional_light_radius[MAX_LIGHTS];     // angular radius (background disc)

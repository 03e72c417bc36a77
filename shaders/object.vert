layout(location = 0) in vec3 position;  // mesh space
layout(location = 1) in vec3 normal;
uniform mat4 model;                     // mesh -> camera-relative world (eye at the origin)
uniform mat4 viewProjection;            // camera-relative world -> clip
uniform mat3 normalMatrix;              // mesh -> world normals
out vec3 relPosition;                   // camera-relative world position
out vec3 worldNormal;
void main() {
    vec4 p = model * vec4(position, 1.0);
    relPosition = p.xyz;
    worldNormal = normalMatrix * normal;
    gl_Position = viewProjection * p;
}

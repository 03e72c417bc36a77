// Depth and stencil only: no colour is written (the colour mask is off).
out vec4 unused;
void main() { unused = vec4(0.0); }

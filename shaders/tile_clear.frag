// Reuse (EllipsoidSettings::reuse): a fresh tile's rectangle set to the tile pass's clear value,
// in an atlas layer whose other tiles are kept (blending off).
uniform vec4 clearTerms;
out vec4 result;
void main() { result = clearTerms; }

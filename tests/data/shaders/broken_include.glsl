// An included file: its lines must not shift the line numbers of broken.frag.
float helper() { return 1.0; }

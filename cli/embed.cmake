# Turns INPUT into a C++ source defining the embedded default mesh (bytes and name).
file(READ ${INPUT} hex HEX)
string(LENGTH "${hex}" n)
math(EXPR size "${n} / 2")
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
string(REGEX REPLACE "(0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,)" "\\1\n" bytes "${bytes}")
file(WRITE ${OUTPUT} "// Generated from ${INPUT} by cli/embed.cmake. Do not edit.\n#include <string_view>\nnamespace ricci_cli {\nstatic const unsigned char kBytes[] = {\n${bytes}0};\nstd::string_view embedded_default_mesh() { return {reinterpret_cast<const char*>(kBytes), ${size}}; }\nconst char* embedded_default_name() { return \"${NAME}\"; }\n}  // namespace ricci_cli\n")

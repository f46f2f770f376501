# cmake -DIN=file -DOUT=file.cpp -P EmbedText.cmake : the text of IN as vgr::config::embeddedSimCellYaml().
file(READ ${IN} content)
file(WRITE ${OUT} "// Generated from ${IN}; do not edit.\n#include <string>\nnamespace vgr::config {\nconst std::string& embeddedSimCellYaml() {\n  static const std::string text = R\"vgr_yaml(${content})vgr_yaml\";\n  return text;\n}\n}  // namespace vgr::config\n")

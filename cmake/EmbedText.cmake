# cmake -DIN=file -DOUT=file.cpp -DNAME=function -P EmbedText.cmake : the text of IN as
# `const std::string& vgr::config::NAME()`.
file(READ ${IN} content)
file(WRITE ${OUT} "// Generated from ${IN}; do not edit.\n#include <string>\nnamespace vgr::config {\nconst std::string& ${NAME}() {\n  static const std::string text = R\"vgr_yaml(${content})vgr_yaml\";\n  return text;\n}\n}  // namespace vgr::config\n")

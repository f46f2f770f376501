# cmake -DIN=file -DOUT=file.cpp -DNAME=function [-DNAMESPACE=ns] -P EmbedText.cmake : the text
# of IN as `const std::string& NAMESPACE::NAME()` (NAMESPACE default: vgr::config).
if(NOT NAMESPACE)
  set(NAMESPACE vgr::config)
endif()
file(READ ${IN} content)
file(WRITE ${OUT} "// Generated from ${IN}; do not edit.\n#include <string>\nnamespace ${NAMESPACE} {\nconst std::string& ${NAME}() {\n  static const std::string text = R\"vgr_yaml(${content})vgr_yaml\";\n  return text;\n}\n}  // namespace ${NAMESPACE}\n")

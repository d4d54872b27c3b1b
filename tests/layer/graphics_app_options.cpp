// graphics_app's flags (graphics_app.hpp).
#include <cstdio>
#include <cstdlib>

#include "graphics_app.hpp"

namespace {

[[noreturn]] void refuse(const std::string& message) {
  std::fprintf(stderr, "graphics_app: %s\n", message.c_str());
  std::exit(1);
}

uint32_t number(const std::string& flag, const std::string& value) {
  char* end = nullptr;
  const unsigned long v = std::strtoul(value.c_str(), &end, 10);
  if (value.empty() || *end != '\0') refuse(flag + ": expected a number, got " + value);
  return uint32_t(v);
}

}  // namespace

Options parseOptions(int argc, char** argv) {
  Options o;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--frames") o.frames = number(flag, value);
    else if (flag == "--width") o.width = number(flag, value);
    else if (flag == "--height") o.height = number(flag, value);
    else if (flag == "--push-set") o.pushSet = number(flag, value) ? 1 : 0;
    else if (flag == "--pipeline") o.pipeline = value;
    else if (flag == "--descriptors") o.descriptors = value;
    else if (flag == "--draw") o.draw = value;
    else if (flag == "--submit") o.submit = value;
    else if (flag == "--indirect-draws") {
      o.indirect.clear();
      for (size_t at = 0; at < value.size();) {
        size_t end = value.find(',', at);
        if (end == std::string::npos) end = value.size();
        const std::string item = value.substr(at, end - at);
        const size_t x = item.find('x');
        if (x == std::string::npos) refuse("--indirect-draws: expected COUNTxINSTANCES, got " + item);
        o.indirect.emplace_back(number(flag, item.substr(0, x)), number(flag, item.substr(x + 1)));
        at = end + 1;
      }
    } else {
      refuse("unknown flag " + flag);
    }
  }
  if (o.pipeline != "monolithic" && o.pipeline != "library" && o.pipeline != "library-independent") {
    refuse("--pipeline: monolithic, library or library-independent");
  }
  if (o.descriptors != "sets" && o.descriptors != "push" && o.descriptors != "push-template") {
    refuse("--descriptors: sets, push or push-template");
  }
  if (o.draw != "direct" && o.draw != "indirect" && o.draw != "indirect-count") {
    refuse("--draw: direct, indirect or indirect-count");
  }
  if (o.submit != "fence" && o.submit != "none" && o.submit != "submit2-fence" && o.submit != "submit2-none") {
    refuse("--submit: fence, none, submit2-fence or submit2-none");
  }
  return o;
}

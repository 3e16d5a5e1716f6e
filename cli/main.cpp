// nhnet-cli: placeholder entry point, replaced by the CLI work on issue 2.
#include "nhnet/version.hpp"

#include <cstdio>

int main() {
  std::printf("nhnet-cli %s\n", nhnet::version());
  return 0;
}

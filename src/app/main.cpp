/// @file main.cpp
/// @brief aoscan command line entry point.
#include <cstdio>

int main() {
  std::puts("aoscan " AOSCAN_VERSION);
  return 0;
}

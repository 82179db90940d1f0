#pragma once
// What the README's library example must have done, checked after it runs (checks.inc):
// the headers those checks need.
#include <chrono>
#include <cstdio>
#include <thread>

#include "lamina/io/model_file.h"

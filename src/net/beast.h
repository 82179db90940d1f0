#pragma once
// Boost.Beast and Boost.Asio (Debian's Boost 1.74, header-only) for the web edge and its tests.
// Boost 1.74's asio/awaitable.hpp uses std::exchange without including <utility>, which GCC 12
// in C++20 does not bring in on its own: <utility> first, and the order kept as it is.
// clang-format off
#include <utility>
#include <boost/asio.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>
// clang-format on

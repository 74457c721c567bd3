/*---------------------------------------------------------------------------*\
    stepServerClient, the socket stream: where to connect, connecting with
    retries, sending and receiving bytes with the reply timeout
    (docs/protocol.md, docs/openfoam-plugin.md)
\*---------------------------------------------------------------------------*/

#include "stepServerClient.H"

#include <arpa/inet.h>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sstream>
#include <sys/socket.h>
#include <sys/un.h>
#include <thread>
#include <unistd.h>

namespace stepServer
{

namespace
{

using Clock = std::chrono::steady_clock;

std::string errnoString(int e)
{
    return std::string(std::strerror(e));
}

} // End anonymous namespace


// * * * * * * * * * * * * * * * * Endpoint  * * * * * * * * * * * * * * * * //

std::string Endpoint::describe() const
{
    if (port > 0)
    {
        std::ostringstream os;
        os << "tcp://" << host << ':' << port;
        return os.str();
    }
    return socketPath;
}


// * * * * * * * * * * * * * * * Socket stream * * * * * * * * * * * * * * //

int stepServerClient::tryConnectOnce(std::string& why) const
{
    int fd = -1;
    if (endpoint_.port > 0)
    {
        sockaddr_in addr{};
        addr.sin_family = AF_INET;
        addr.sin_port = htons(std::uint16_t(endpoint_.port));
        if (inet_pton(AF_INET, endpoint_.host.c_str(), &addr.sin_addr) != 1)
        {
            throw stepServerError
            (
                "host '" + endpoint_.host + "' is not a numeric IPv4 address"
            );
        }
        fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (fd < 0)
        {
            why = "socket(): " + errnoString(errno);
            return -1;
        }
        // Non-blocking connect bounded by the connect timeout
        int flags = ::fcntl(fd, F_GETFL, 0);
        ::fcntl(fd, F_SETFL, flags | O_NONBLOCK);
        int rc = ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr));
        if (rc < 0 && errno == EINPROGRESS)
        {
            pollfd pfd{fd, POLLOUT, 0};
            int ms = int(std::max(1.0, 1000*endpoint_.connectTimeout));
            rc = ::poll(&pfd, 1, ms);
            if (rc == 1)
            {
                int err = 0;
                socklen_t len = sizeof(err);
                ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
                rc = (err == 0) ? 0 : -1;
                errno = err;
            }
            else
            {
                rc = -1;
                errno = ETIMEDOUT;
            }
        }
        if (rc < 0)
        {
            why = errnoString(errno);
            ::close(fd);
            return -1;
        }
        ::fcntl(fd, F_SETFL, flags);
        int one = 1;
        ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    }
    else
    {
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        if (endpoint_.socketPath.size() >= sizeof(addr.sun_path))
        {
            throw stepServerError
            (
                "socket path '" + endpoint_.socketPath + "' is longer than "
              + std::to_string(sizeof(addr.sun_path) - 1)
              + " characters: use a shorter case path or TCP (port)"
            );
        }
        std::strncpy
        (
            addr.sun_path, endpoint_.socketPath.c_str(),
            sizeof(addr.sun_path) - 1
        );
        fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (fd < 0)
        {
            why = "socket(): " + errnoString(errno);
            return -1;
        }
        if
        (
            ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr))
          < 0
        )
        {
            why = errnoString(errno);
            ::close(fd);
            return -1;
        }
    }
    return fd;
}


void stepServerClient::sendAll(const std::vector<unsigned char>& buf)
{
    std::size_t done = 0;
    while (done < buf.size())
    {
        ssize_t n = ::send(fd_, buf.data() + done, buf.size() - done, MSG_NOSIGNAL);
        if (n < 0)
        {
            if (errno == EINTR) continue;
            fail("send failed: " + errnoString(errno) + "; did the server stop?");
        }
        done += std::size_t(n);
    }
}


void stepServerClient::recvAll(unsigned char* buf, std::size_t n)
{
    const auto deadline =
        Clock::now()
      + std::chrono::duration_cast<Clock::duration>
        (
            std::chrono::duration<double>(endpoint_.replyTimeout)
        );

    std::size_t done = 0;
    while (done < n)
    {
        auto left = std::chrono::duration_cast<std::chrono::milliseconds>
        (
            deadline - Clock::now()
        ).count();
        if (left <= 0)
        {
            std::ostringstream os;
            os << "no reply within replyTimeout " << endpoint_.replyTimeout
               << " s";
            fail(os.str());
        }
        pollfd pfd{fd_, POLLIN, 0};
        int rc = ::poll(&pfd, 1, int(std::min<long long>(left, 1000000)));
        if (rc < 0)
        {
            if (errno == EINTR) continue;
            fail("poll failed: " + errnoString(errno));
        }
        if (rc == 0) continue;   // deadline checked above

        ssize_t got = ::recv(fd_, buf + done, n - done, 0);
        if (got < 0)
        {
            if (errno == EINTR || errno == EAGAIN) continue;
            fail("receive failed: " + errnoString(errno) + "; did the server stop?");
        }
        if (got == 0)
        {
            fail("the server closed the connection (EOF); did it stop or crash?");
        }
        done += std::size_t(got);
    }
}


void stepServerClient::connect()
{
    if (fd_ >= 0) return;

    const auto start = Clock::now();
    std::string why;
    int attempts = 0;
    while (true)
    {
        ++attempts;
        fd_ = tryConnectOnce(why);
        if (fd_ >= 0)
        {
            seq_ = 0;
            return;
        }
        const double waited =
            std::chrono::duration<double>(Clock::now() - start).count();
        if (waited >= endpoint_.connectTimeout)
        {
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }

    std::ostringstream os;
    os << "cannot connect to the step-server at " << endpoint_.describe()
       << " (" << why << ", " << attempts << " attempts in "
       << endpoint_.connectTimeout << " s)";
    throw stepServerError(os.str());
}


void stepServerClient::close() noexcept
{
    if (fd_ >= 0)
    {
        ::close(fd_);
        fd_ = -1;
    }
}

} // End namespace stepServer

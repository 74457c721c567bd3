/*---------------------------------------------------------------------------*\
    stepServerStream, the socket stream: connecting with retries, sending
    and receiving bytes with the reply timeout
    (docs/protocol.md, docs/openfoam-plugin.md)
\*---------------------------------------------------------------------------*/

#include "stepServerStream.H"

#include <algorithm>
#include <arpa/inet.h>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fcntl.h>
#include <netdb.h>
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


// * * * * * * * * * * * * * * * Socket stream * * * * * * * * * * * * * * //

namespace
{

//- Connect fd to addr within timeoutMs; 0 or -1 with errno set
int connectWithin(int fd, const sockaddr* addr, socklen_t len, int timeoutMs)
{
    const int flags = ::fcntl(fd, F_GETFL, 0);
    ::fcntl(fd, F_SETFL, flags | O_NONBLOCK);
    int rc = ::connect(fd, addr, len);
    if (rc < 0 && errno == EINPROGRESS)
    {
        pollfd pfd{fd, POLLOUT, 0};
        rc = ::poll(&pfd, 1, timeoutMs);
        if (rc == 1)
        {
            int err = 0;
            socklen_t elen = sizeof(err);
            ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &elen);
            rc = (err == 0) ? 0 : -1;
            errno = err;
        }
        else
        {
            rc = -1;
            errno = ETIMEDOUT;
        }
    }
    if (rc == 0)
    {
        ::fcntl(fd, F_SETFL, flags);
    }
    return rc;
}


//- TCP to a host name or address, IPv4 or IPv6 (getaddrinfo, every
//  address in turn)
int connectTcp(const Endpoint& ep, std::string& why)
{
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* res = nullptr;
    const std::string port = std::to_string(ep.port);
    const int gai = ::getaddrinfo(ep.host.c_str(), port.c_str(), &hints, &res);
    if (gai != 0)
    {
        why = "cannot resolve host '" + ep.host + "': " + ::gai_strerror(gai);
        return -1;
    }
    const int ms = int(std::max(1.0, 1000 * std::min(ep.connectTimeout, 5.0)));
    int fd = -1;
    for (addrinfo* ai = res; ai && fd < 0; ai = ai->ai_next)
    {
        fd = ::socket(
            ai->ai_family,
            ai->ai_socktype | SOCK_CLOEXEC,
            ai->ai_protocol
        );
        if (fd < 0)
        {
            why = "socket(): " + errnoString(errno);
            continue;
        }
        if (connectWithin(fd, ai->ai_addr, ai->ai_addrlen, ms) < 0)
        {
            why = errnoString(errno);
            ::close(fd);
            fd = -1;
            continue;
        }
        int one = 1;
        ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    }
    ::freeaddrinfo(res);
    return fd;
}


//- A UNIX socket; a path too long for sun_path goes through
//  /proc/self/fd/<dir fd>/<name> (Linux), as the server binds it
int connectUnix(const std::string& path, std::string& why)
{
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::string target = path;
    int dirFd = -1;
    if (target.size() >= sizeof(addr.sun_path))
    {
        const auto slash = path.rfind('/');
        const std::string dir =
            slash == std::string::npos ? "." : path.substr(0, slash);
        dirFd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (dirFd < 0)
        {
            why = "cannot open " + dir + ": " + errnoString(errno);
            return -1;
        }
        target = "/proc/self/fd/" + std::to_string(dirFd) + "/"
            + path.substr(slash + 1);
    }
    std::strncpy(addr.sun_path, target.c_str(), sizeof(addr.sun_path) - 1);
    int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0)
    {
        why = "socket(): " + errnoString(errno);
    }
    else if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr))
             < 0)
    {
        why = errnoString(errno);
        ::close(fd);
        fd = -1;
    }
    if (dirFd >= 0) ::close(dirFd);
    return fd;
}

} // End anonymous namespace


// * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * * //

stepServerStream::stepServerStream(const Endpoint& ep) :
    endpoint_(ep)
{}


stepServerStream::~stepServerStream()
{
    close();
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

int stepServerStream::tryConnectOnce(std::string& why)
{
    Endpoint target;
    if (!endpoint_.resolve(target, why))
    {
        return -1;
    }
    connectedTo_ = target.describe();
    return target.port > 0 ? connectTcp(target, why)
                           : connectUnix(target.socketPath, why);
}


void stepServerStream::connect()
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
       << (connectedTo_.empty() || connectedTo_ == endpoint_.describe()
               ? std::string()
               : " (" + connectedTo_ + ")")
       << " (" << why << ", " << attempts << " attempts in "
       << endpoint_.connectTimeout << " s)";
    throw stepServerError(os.str());
}


void stepServerStream::sendAll(const std::vector<unsigned char>& buf)
{
    std::size_t done = 0;
    while (done < buf.size())
    {
        ssize_t n =
            ::send(fd_, buf.data() + done, buf.size() - done, MSG_NOSIGNAL);
        if (n < 0)
        {
            if (errno == EINTR) continue;
            fail(
                "the step-server stopped or crashed: sending to it failed ("
                + errnoString(errno) + ")"
            );
        }
        done += std::size_t(n);
    }
}


void stepServerStream::recvAll(unsigned char* buf, std::size_t n)
{
    const auto deadline =
        Clock::now()
        + std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double>(endpoint_.replyTimeout)
        );

    std::size_t done = 0;
    while (done < n)
    {
        auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                        deadline - Clock::now()
        )
                        .count();
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
        if (rc == 0) continue; // deadline checked above

        ssize_t got = ::recv(fd_, buf + done, n - done, 0);
        if (got < 0)
        {
            if (errno == EINTR || errno == EAGAIN) continue;
            fail(
                "the step-server stopped or crashed: receiving from it failed ("
                + errnoString(errno) + ")"
            );
        }
        if (got == 0)
        {
            fail("the step-server closed the connection (EOF): it stopped or "
                 "crashed");
        }
        done += std::size_t(got);
    }
}


std::string stepServerStream::where() const
{
    if (endpoint_.endpointFile.empty() || connectedTo_.empty()
        || connectedTo_ == endpoint_.describe())
    {
        return "step-server at " + endpoint_.describe();
    }
    return "step-server at " + connectedTo_ + ", named in "
        + endpoint_.endpointFile;
}


void stepServerStream::fail(const std::string& msg)
{
    close();
    throw stepServerError(msg + " (" + where() + ")");
}


void stepServerStream::close() noexcept
{
    if (fd_ >= 0)
    {
        ::close(fd_);
        fd_ = -1;
    }
}

} // End namespace stepServer

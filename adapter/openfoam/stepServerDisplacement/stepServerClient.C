/*---------------------------------------------------------------------------*\
    stepServerClient: socket and wire format of docs/protocol.md (version 1)
\*---------------------------------------------------------------------------*/

#include "stepServerClient.H"

#include <arpa/inet.h>
#include <cerrno>
#include <chrono>
#include <cmath>
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

// Little-endian encoding, independent of the host byte order

void putU16(std::vector<unsigned char>& b, std::uint16_t v)
{
    b.push_back(v & 0xff);
    b.push_back((v >> 8) & 0xff);
}

void putU32(std::vector<unsigned char>& b, std::uint32_t v)
{
    for (int i = 0; i < 4; ++i)
    {
        b.push_back((v >> (8*i)) & 0xff);
    }
}

void putF64(std::vector<unsigned char>& b, double d)
{
    std::uint64_t v;
    std::memcpy(&v, &d, 8);
    for (int i = 0; i < 8; ++i)
    {
        b.push_back((v >> (8*i)) & 0xff);
    }
}

std::uint16_t getU16(const unsigned char* p)
{
    return std::uint16_t(p[0] | (p[1] << 8));
}

std::uint32_t getU32(const unsigned char* p)
{
    return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8)
         | (std::uint32_t(p[2]) << 16) | (std::uint32_t(p[3]) << 24);
}

double getF64(const unsigned char* p)
{
    std::uint64_t v = 0;
    for (int i = 0; i < 8; ++i)
    {
        v |= std::uint64_t(p[i]) << (8*i);
    }
    double d;
    std::memcpy(&d, &v, 8);
    return d;
}

const char* typeName(std::uint16_t t)
{
    switch (t)
    {
        case stepServerClient::HELLO: return "HELLO";
        case stepServerClient::WELCOME: return "WELCOME";
        case stepServerClient::REQUEST: return "REQUEST";
        case stepServerClient::DISPLACEMENT: return "DISPLACEMENT";
        case stepServerClient::WRITE: return "WRITE";
        case stepServerClient::ACK: return "ACK";
        case stepServerClient::BYE: return "BYE";
        case stepServerClient::ERROR: return "ERROR";
        default: return "unknown";
    }
}

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


// * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * * //

stepServerClient::stepServerClient(const Endpoint& ep)
:
    endpoint_(ep)
{}


stepServerClient::~stepServerClient()
{
    close();
}


// * * * * * * * * * * * * * * Private helpers  * * * * * * * * * * * * * * //

void stepServerClient::fail(const std::string& msg)
{
    close();
    throw stepServerError(msg + " (server " + endpoint_.describe() + ")");
}


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


std::uint32_t stepServerClient::sendFrame
(
    MsgType type,
    const std::vector<unsigned char>& payload
)
{
    if (fd_ < 0)
    {
        throw stepServerError
        (
            std::string("cannot send ") + typeName(type)
          + ": not connected to " + endpoint_.describe()
        );
    }
    std::vector<unsigned char> buf;
    buf.reserve(16 + payload.size());
    buf.push_back('W'); buf.push_back('H'); buf.push_back('A'); buf.push_back('L');
    putU16(buf, version);
    putU16(buf, type);
    putU32(buf, std::uint32_t(payload.size()));
    const std::uint32_t seq = ++seq_;
    putU32(buf, seq);
    buf.insert(buf.end(), payload.begin(), payload.end());
    sendAll(buf);
    return seq;
}


std::vector<unsigned char> stepServerClient::recvReply
(
    std::uint32_t seq,
    MsgType expected,
    const char* what
)
{
    unsigned char h[16];
    recvAll(h, 16);

    const std::string ctx = std::string(" in reply to ") + what;
    if (std::memcmp(h, "WHAL", 4) != 0)
    {
        fail("malformed reply" + ctx + ": bad magic");
    }
    const std::uint16_t ver = getU16(h + 4);
    const std::uint16_t type = getU16(h + 6);
    const std::uint32_t len = getU32(h + 8);
    const std::uint32_t rseq = getU32(h + 12);

    if (len > maxPayload)
    {
        fail("malformed reply" + ctx + ": payload length " + std::to_string(len)
           + " over the 64 MiB limit");
    }
    std::vector<unsigned char> payload(len);
    if (len) recvAll(payload.data(), len);

    if (type == ERROR)
    {
        std::uint32_t code = len >= 4 ? getU32(payload.data()) : 0;
        std::string msg
        (
            len > 4 ? reinterpret_cast<const char*>(payload.data()) + 4 : "",
            len > 4 ? len - 4 : 0
        );
        fail("server ERROR " + std::to_string(code) + ctx + ": " + msg);
    }
    if (ver != version)
    {
        fail("protocol version mismatch" + ctx + ": server speaks "
           + std::to_string(ver) + ", client " + std::to_string(version));
    }
    if (type != expected)
    {
        fail(std::string("unexpected ") + typeName(type) + " (type "
           + std::to_string(type) + ")" + ctx + ", expected "
           + typeName(expected));
    }
    if (rseq != seq)
    {
        fail("reply" + ctx + " carries sequence number "
           + std::to_string(rseq) + ", expected " + std::to_string(seq));
    }
    return payload;
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

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


Welcome stepServerClient::hello
(
    std::uint32_t rank,
    std::uint32_t nRanks,
    const std::string& token,
    const std::vector<double>& points
)
{
    if (points.size() % 3)
    {
        throw stepServerError("HELLO: point array size not a multiple of 3");
    }
    nPoints_ = points.size()/3;

    std::vector<unsigned char> p;
    p.reserve(16 + token.size() + 8*points.size());
    putU32(p, rank);
    putU32(p, nRanks);
    putU32(p, std::uint32_t(nPoints_));
    putU32(p, std::uint32_t(token.size()));
    p.insert(p.end(), token.begin(), token.end());
    for (double x : points) putF64(p, x);

    const std::uint32_t seq = sendFrame(HELLO, p);
    const auto r = recvReply(seq, WELCOME, "HELLO");
    if (r.size() != 20)
    {
        fail("malformed WELCOME: payload of " + std::to_string(r.size())
           + " bytes, expected 20");
    }
    Welcome w;
    w.nPoints = getU32(r.data());
    w.maxMappingDistance = getF64(r.data() + 4);
    w.internalStep = getF64(r.data() + 12);
    if (w.nPoints != nPoints_)
    {
        fail("WELCOME accepted " + std::to_string(w.nPoints)
           + " points, but HELLO sent " + std::to_string(nPoints_));
    }
    return w;
}


std::vector<double> stepServerClient::request
(
    double t,
    const std::array<double, 3>& pressureForce,
    const std::array<double, 3>& viscousForce
)
{
    std::vector<unsigned char> p;
    p.reserve(56);
    putF64(p, t);
    for (double f : pressureForce) putF64(p, f);
    for (double f : viscousForce) putF64(p, f);

    const std::uint32_t seq = sendFrame(REQUEST, p);
    const auto r = recvReply(seq, DISPLACEMENT, "REQUEST");

    const std::size_t expected = 12 + 24*nPoints_;
    if (r.size() < 12 || r.size() != expected)
    {
        fail("malformed DISPLACEMENT: payload of " + std::to_string(r.size())
           + " bytes, expected " + std::to_string(expected)
           + " for " + std::to_string(nPoints_) + " points");
    }
    const double rt = getF64(r.data());
    const std::uint32_t n = getU32(r.data() + 8);
    if (n != nPoints_)
    {
        fail("DISPLACEMENT for " + std::to_string(n) + " points, expected "
           + std::to_string(nPoints_));
    }
    if (rt != t)
    {
        std::ostringstream os;
        os.precision(17);
        os << "DISPLACEMENT for time " << rt << ", requested " << t;
        fail(os.str());
    }
    std::vector<double> d(3*nPoints_);
    for (std::size_t i = 0; i < d.size(); ++i)
    {
        d[i] = getF64(r.data() + 12 + 8*i);
        if (!std::isfinite(d[i]))
        {
            fail("DISPLACEMENT contains a non-finite value at point "
               + std::to_string(i/3));
        }
    }
    return d;
}


void stepServerClient::write(double t)
{
    std::vector<unsigned char> p;
    putF64(p, t);
    const std::uint32_t seq = sendFrame(WRITE, p);
    const auto r = recvReply(seq, ACK, "WRITE");
    if (!r.empty())
    {
        fail("malformed ACK: payload of " + std::to_string(r.size())
           + " bytes, expected 0");
    }
}


void stepServerClient::bye() noexcept
{
    if (fd_ < 0) return;
    try
    {
        sendFrame(BYE, {});
    }
    catch (...)
    {}
    close();
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
